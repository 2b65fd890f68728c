"""A `Series` as text SymPy parses and as LaTeX.

Names: the coordinates are q1 … qn and the velocities dq1 … dqn, in the order of the model's
joints (q and v). Numbers are written to round-trip precision: the coefficient is rounded to the
nearest double and written as Python's `repr` of it (the shortest decimal that reads back to the
same double, at most 17 significant digits), so `0.7` stays `0.7`.

Layout: the terms are grouped by their monomial in the prismatic coordinates and velocities
(dq1*dq2, q3**2, …): a group of one term is written as one product, a larger group as the
monomial times its trigonometric polynomial in parentheses, e.g.
`dq2*(-0.5*sin(q2) + 0.25*sin(2*q2 + q3))`. Within a group the constant comes first, then the
terms by increasing order of their frequency vector (cos before sin for the same angle).
"""

from __future__ import annotations

import functools
from collections import defaultdict
from decimal import Decimal

from service.dynamics.equations.series import COS, Series, unpack_key

Term = tuple[tuple[int, ...], tuple[int, ...], int]  # (k, e, kind) unpacked


def _number(c: Decimal) -> str:
    return repr(float(c))


def _latex_number(c: Decimal) -> str:
    text = repr(float(c))
    if "e" in text:
        mantissa, exponent = text.split("e")
        return rf"{mantissa} \cdot 10^{{{int(exponent)}}}"
    return text


@functools.lru_cache(maxsize=1 << 16)
def _angle(k: tuple[int, ...], latex: bool) -> str:
    parts: list[str] = []
    for i, ki in enumerate(k):
        if not ki:
            continue
        name = f"q_{{{i + 1}}}" if latex else f"q{i + 1}"
        size = abs(ki)
        factor = name if size == 1 else (f"{size} {name}" if latex else f"{size}*{name}")
        if not parts:
            parts.append(factor if ki > 0 else f"-{factor}")
        else:
            parts.append(f"{'+' if ki > 0 else '-'} {factor}")
    return " ".join(parts)


@functools.lru_cache(maxsize=1 << 12)
def _monomial(e: tuple[int, ...], n: int, latex: bool) -> tuple[str, ...]:
    factors = []
    for i, ei in enumerate(e):
        if not ei:
            continue
        j = i % n + 1
        if latex:
            base = f"q_{{{j}}}" if i < n else rf"\dot{{q}}_{{{j}}}"
            factors.append(base if ei == 1 else f"{base}^{{{ei}}}")
        else:
            base = f"q{j}" if i < n else f"dq{j}"
            factors.append(base if ei == 1 else f"{base}**{ei}")
    return tuple(factors)


@functools.lru_cache(maxsize=1 << 16)
def _trig(k: tuple[int, ...], kind: int, latex: bool) -> tuple[str, ...]:
    if not any(k):
        return ()
    fn = "cos" if kind == COS else "sin"
    angle = _angle(k, latex)
    return (rf"\{fn}\left({angle}\right)" if latex else f"{fn}({angle})",)


def _product(c: Decimal, factors: list[str], latex: bool) -> str:
    """c times the factors, the sign first: '-0.5*dq1*sin(q2)'."""
    joiner = " " if latex else "*"
    magnitude = c.copy_abs()
    parts = list(factors)
    if magnitude != 1 or not parts:
        parts.insert(0, _latex_number(magnitude) if latex else _number(magnitude))
    return ("-" if c < 0 else "") + joiner.join(parts)


def _sum(products: list[str]) -> str:
    out = products[0]
    for p in products[1:]:
        out += f" - {p[1:]}" if p.startswith("-") else f" + {p}"
    return out


def _order(key: Term) -> tuple[int, tuple[int, ...], int]:
    k, _, kind = key
    return (sum(abs(x) for x in k), tuple(-x for x in k), kind)


def _monomial_order(e: tuple[int, ...]) -> tuple[int, tuple[int, ...]]:
    return (sum(e), tuple(-x for x in e))


def render(series: Series, latex: bool = False) -> str:
    """The series as SymPy-parsable text (`latex=False`) or as LaTeX; "0" when it is zero."""
    if series.is_zero():
        return "0"
    n = series.n
    groups: dict[tuple[int, ...], list[tuple[Term, Decimal]]] = defaultdict(list)
    for packed, c in series.terms.items():
        key = unpack_key(packed, n)
        groups[key[1]].append((key, c))
    products: list[str] = []
    for e in sorted(groups, key=_monomial_order):
        terms = sorted(groups[e], key=lambda t: _order(t[0]))
        mono = _monomial(e, n, latex)
        if len(terms) == 1 or not mono:
            for (k, _, kind), c in terms:
                products.append(_product(c, [*mono, *_trig(k, kind, latex)], latex))
            continue
        inner = _sum([_product(c, list(_trig(k, kind, latex)), latex)
                      for (k, _, kind), c in terms])
        open_, close = (r"\left(", r"\right)") if latex else ("(", ")")
        products.append(_product(Decimal(1), [*mono, f"{open_}{inner}{close}"], latex))
    return _sum(products)
