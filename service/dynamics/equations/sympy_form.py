"""A `Series` as a SymPy expression: the reference the printed text is checked against, and
what a script that wants SymPy objects uses (`to_sympy(entry)`).

Names: the coordinates are the symbols q1 … qn and the velocities dq1 … dqn, in the order of the
model's joints (q and v), the parameters p1 … pr. A term a · p · x^e · cos(k·q) becomes
`a * p * x1**e1 * … * cos(k1*q1 + …)` with `sp.cos`/`sp.sin` of the integer combination of the q
symbols. Each coefficient is the nearest double as a SymPy `Float` of `FLOAT_DIGITS` = 17
significant digits, or an exact `Integer` when that double is a whole number below 2⁵³.
"""

from __future__ import annotations

import functools
from decimal import Decimal

import sympy as sp

from service.dynamics.equations.series import COS, Series, parameter_index, unpack_key

FLOAT_DIGITS = 17
_EXACT_INTEGERS = 2**53


@functools.lru_cache(maxsize=64)
def coordinate(i: int) -> sp.Symbol:
    """The symbol q{i+1} of coordinate i (from 0): rad or m."""
    return sp.Symbol(f"q{i + 1}")


@functools.lru_cache(maxsize=64)
def velocity(i: int) -> sp.Symbol:
    """The symbol dq{i+1} of velocity i (from 0): rad/s or m/s."""
    return sp.Symbol(f"dq{i + 1}")


@functools.lru_cache(maxsize=256)
def parameter(j: int) -> sp.Symbol:
    """The symbol p{j} of base parameter j (from 1)."""
    return sp.Symbol(f"p{j}")


def symbols(n: int) -> dict[str, sp.Symbol]:
    """The names the text uses for n joints, as `sympify(..., locals=symbols(n))` takes them."""
    out = {f"q{i + 1}": coordinate(i) for i in range(n)}
    out.update({f"dq{i + 1}": velocity(i) for i in range(n)})
    return out


def number(c: Decimal) -> sp.Expr:
    """The coefficient c as the nearest double: an `Integer` when it is a whole number, else a
    17-digit `Float` of its shortest round-trip decimal."""
    x = float(c)
    if x.is_integer() and abs(x) < _EXACT_INTEGERS:
        return sp.Integer(int(x))
    return sp.Float(repr(x), FLOAT_DIGITS)


@functools.lru_cache(maxsize=1 << 16)
def _trig(k: tuple[int, ...], kind: int) -> sp.Expr:
    angle = sp.Add(*[ki * coordinate(i) for i, ki in enumerate(k) if ki])
    return sp.cos(angle) if kind == COS else sp.sin(angle)


@functools.lru_cache(maxsize=1 << 12)
def _monomial(e: tuple[int, ...], n: int) -> sp.Expr:
    factors = []
    for i, ei in enumerate(e):
        if ei:
            base = coordinate(i) if i < n else velocity(i - n)
            factors.append(base if ei == 1 else sp.Pow(base, ei))
    return sp.Mul(*factors)


def to_sympy(series: Series) -> sp.Expr:
    """The series as a SymPy expression in the symbols q1 … qn, dq1 … dqn, p1 … (see the
    module docstring); `sp.Integer(0)` when it is zero."""
    n = series.n
    groups: dict[tuple[int, ...], list[sp.Expr]] = {}
    for packed, c in series.terms.items():
        k, e, kind = unpack_key(packed, n)
        term = number(c) if not any(k) else sp.Mul(number(c), _trig(k, kind))
        j = parameter_index(packed[1], n)
        if j:
            term = sp.Mul(parameter(j), term)
        groups.setdefault(e, []).append(term)
    parts = []
    for e, terms in groups.items():
        mono = _monomial(e, n)
        inner = sp.Add(*terms)
        parts.append(inner if not any(e) else sp.Mul(mono, inner))
    return sp.Add(*parts)
