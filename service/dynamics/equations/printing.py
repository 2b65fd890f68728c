"""Text and LaTeX of a `Series`, printed from its terms directly, rounded and cut.

Names: the coordinates are q1 … qn and the velocities dq1 … dqn, in the order of the model's
joints (q and v); a parametric term's parameter symbol is p1 … pr. A term a · p · x^e · cos(k·q)
is written `a*p3*dq1**2*cos(q1 + 2*q2)` (text, which SymPy's `sympify` reads) and
`a p_{3} \\dot{q}_{1}^{2} \\cos{\\left(q_{1} + 2 q_{2} \\right)}` (LaTeX).

Numbers: a coefficient is rounded to `digits` significant digits (1–17); with 17 it is the
nearest double written as its shortest round-trip decimal (Python's `repr`). A whole number
below 2⁵³ is written as an integer, and a factor 1 is not written (`cos(q2)`). Terms whose
coefficient is below the absolute `cut` are left out.

Layout: the terms are grouped by their factor in the parameter, the velocities and the
prismatic coordinates (a group of several terms is the factor times their sum:
`dq2*(-0.5*sin(q2) + 0.25*sin(2*q2 + q3))`), the groups in the order of their parameter, then of
their factor's degree; inside a group the terms are ordered by the coordinates they depend on
(the constant first, then the terms in q2 alone, in q2 and q3, …, each by frequency), so an
entry reads as a short trigonometric polynomial, coordinate by coordinate.

Accuracy: `Printed.error` bounds |printed − exact| over every q: the sum, over the terms left
out and the rounding of the kept ones, of |coefficient change| × the largest value of the term's
factor (|cos|, |sin| ≤ 1; a velocity counts 1, so the bound is per unit of ‖q̇‖∞ to the power
of the factor's degree; a prismatic coordinate counts its `reach`, the larger magnitude of its
position limits; a parameter counts the magnitude of its value).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from decimal import Decimal

from service.dynamics.equations.series import BASE, COS, Series, unpack

EXACT_DIGITS = 17
_EXACT_INTEGERS = 2**53
_ULP = 2.0**-52  # a bound of the relative rounding of one double operation (with margin)
_DROPPED = 1 + 2 * _ULP  # |c| of a dropped term, with the rounding of c to a double
_ROUNDED = 1 + _ULP


@dataclass(frozen=True)
class Printed:
    """One entry: its text and LaTeX, the bound of |printed − exact| over every q (in the
    entry's units, per unit of ‖q̇‖∞ to the power of its degree in q̇), and the coordinates
    (indices from 0) its printed terms depend on."""

    text: str
    latex: str
    error: float
    depends_on: list[int]


def number(x: float, digits: int) -> str:
    """|x| (x ≠ 0) rounded to `digits` significant digits, as text: an integer when whole,
    the shortest round-trip decimal of the double with 17 digits."""
    x = abs(x)
    if x.is_integer() and x < _EXACT_INTEGERS:
        return str(int(x))
    text = repr(x) if digits >= EXACT_DIGITS else format(x, f".{digits}g")
    if "e" not in text:
        return text
    value = float(text)
    if value.is_integer() and value < _EXACT_INTEGERS:
        return str(int(value))
    return text


def latex_number(text: str) -> str:
    """A number's text in LaTeX: 1.5e-12 as 1.5 \\cdot 10^{-12}."""
    if "e" not in text:
        return text
    mantissa, exponent = text.split("e")
    if mantissa == "1":
        return f"10^{{{int(exponent)}}}"
    return rf"{mantissa} \cdot 10^{{{int(exponent)}}}"


class Printer:
    """Prints the entries of equations over n coordinates (see the module docstring).
    `reach[i]` bounds |q_i| for a prismatic coordinate i (m); `parameter_sizes[j - 1]` is
    |p_j|'s value (the parametric form)."""

    def __init__(
        self,
        n: int,
        digits: int,
        reach: Sequence[float] | None = None,
        parameter_sizes: Sequence[float] = (),
    ) -> None:
        self.n = n
        self.digits = digits
        self.reach = [1.0] * n if reach is None else [float(r) for r in reach]
        self.parameter_sizes = [abs(float(s)) for s in parameter_sizes]
        self._format = f"%.{digits}g"
        self._scale = BASE ** (2 * n)
        self._trig: dict[tuple[int, int], tuple[tuple[int, ...], str, str, int]] = {}
        self._factor: dict[int, tuple[tuple[int, ...], str, str, float, int]] = {}
        # coefficient → (x, |x|, its text, the bound of its rounding): C's coefficients are
        # the Christoffel symbols', T's M's, so each is rounded once
        self._coefficient: dict[Decimal, tuple[float, float, str, float]] = {}

    # -- memoized pieces ---------------------------------------------------------------------
    def _trig_of(self, k: int, kind: int) -> tuple[tuple[int, ...], str, str, int]:
        """(sort key, text, LaTeX, mask of coordinates) of cos(k·q) or sin(k·q); k = 0: ""."""
        found = self._trig.get((k, kind))
        if found is not None:
            return found
        freq = unpack(k, self.n) if k else (0,) * self.n
        used = [i for i, ki in enumerate(freq) if ki]
        text_parts: list[str] = []
        latex_parts: list[str] = []
        for i in used:
            ki = freq[i]
            size = abs(ki)
            sign = "-" if ki < 0 else "+"
            name = f"q{i + 1}" if size == 1 else f"{size}*q{i + 1}"
            tex = f"q_{{{i + 1}}}" if size == 1 else f"{size} q_{{{i + 1}}}"
            if not text_parts:
                text_parts.append(name if ki > 0 else f"-{name}")
                latex_parts.append(tex if ki > 0 else f"- {tex}")
            else:
                text_parts.append(f" {sign} {name}")
                latex_parts.append(f" {sign} {tex}")
        if used:
            angle, angle_tex = "".join(text_parts), "".join(latex_parts)
            fn = "cos" if kind == COS else "sin"
            text = f"{fn}({angle})"
            tex = rf"\{fn}{{\left({angle_tex} \right)}}"
        else:
            text = tex = ""
        key = (len(used), *used, *(abs(x) for x in freq), *freq, kind)
        mask = sum(1 << i for i in used)
        found = (key, text, tex, mask)
        self._trig[(k, kind)] = found
        return found

    def _factor_of(self, e: int) -> tuple[tuple[int, ...], str, str, float, int]:
        """(sort key, text, LaTeX, largest value, mask of coordinates) of a term's factor in
        the parameter, the prismatic coordinates and the velocities."""
        found = self._factor.get(e)
        if found is not None:
            return found
        n = self.n
        j, low = divmod(e, self._scale)
        powers = unpack(low, 2 * n) if low else (0,) * (2 * n)
        text_parts, latex_parts = [], []
        size = 1.0
        if j:
            text_parts.append(f"p{j}")
            latex_parts.append(f"p_{{{j}}}")
            size = self.parameter_sizes[j - 1] if j <= len(self.parameter_sizes) else 1.0
        mask = 0
        for v, power in enumerate(powers):
            if not power:
                continue
            if v < n:
                name, tex = f"q{v + 1}", f"q_{{{v + 1}}}"
                size *= self.reach[v] ** power
                mask |= 1 << v
            else:
                name, tex = f"dq{v - n + 1}", rf"\dot{{q}}_{{{v - n + 1}}}"
            text_parts.append(name if power == 1 else f"{name}**{power}")
            latex_parts.append(tex if power == 1 else f"{tex}^{{{power}}}")
        key = (j, sum(powers), *(-p for p in powers))
        found = (key, "*".join(text_parts), " ".join(latex_parts), size, mask)
        self._factor[e] = found
        return found

    def _rounded(self, c: Decimal) -> tuple[float, float, str, float]:
        """(x, |x|, |x| as printed, the bound of |x − printed| and of the double's rounding)
        of a coefficient c (x its double)."""
        x = float(c)
        ax = x if x >= 0 else -x
        if self.digits >= EXACT_DIGITS:
            shown = repr(ax)
            if shown[-2:] == ".0":
                shown = shown[:-2]
        else:
            shown = self._format % ax
        if "e" in shown:
            shown = number(ax, self.digits)
        change = ax - float(shown)
        found = (x, ax, shown, (change if change >= 0 else -change) * _ROUNDED + ax * _ULP)
        self._coefficient[c] = found
        return found

    # -- one entry ---------------------------------------------------------------------------
    def entry(self, series: Series, cut: float) -> Printed:
        """The series printed (terms with |coefficient| < `cut` left out), with its bound."""
        groups: dict[int, list[tuple[tuple[int, ...], bool, str, str, str]]] = {}
        error = 0.0
        mask = 0
        factor_of, trig_of = self._factor.get, self._trig.get
        coefficient_of = self._coefficient.get
        for (k, e, kind), c in series.terms.items():
            rounded = coefficient_of(c)
            if rounded is None:
                rounded = self._rounded(c)
            x, ax, shown, rounding = rounded
            factor = factor_of(e)
            if factor is None:
                factor = self._factor_of(e)
            if ax < cut:
                error += ax * _DROPPED * factor[3]
                continue
            error += rounding * factor[3]
            trig = trig_of((k, kind))
            if trig is None:
                trig = self._trig_of(k, kind)
            mask |= trig[3] | factor[4]
            group = groups.get(e)
            if group is None:
                group = groups[e] = []
            group.append((trig[0], x < 0, shown, trig[1], trig[2]))
        if not groups:
            return Printed("0", "0", error, [])
        pieces: list[tuple[bool, str, str]] = []
        for e in sorted(groups, key=lambda e: self._factor_of(e)[0]):
            _, f_text, f_tex, _, _ = self._factor_of(e)
            terms = groups[e]
            terms.sort()
            if not f_text:
                pieces.extend(_terms(terms))
            elif len(terms) == 1:  # the number first: 2*p3*cos(q2)
                _, negative, shown, t_text, t_tex = terms[0]
                number_tex = latex_number(shown) if "e" in shown else shown
                shown, number_tex = ("", "") if shown == "1" else (shown, number_tex)
                pieces.append(
                    (
                        negative,
                        "*".join(x for x in (shown, f_text, t_text) if x),
                        " ".join(x for x in (number_tex, f_tex, t_tex) if x),
                    )
                )
            else:
                inner_text, inner_tex = _joined(_terms(terms))
                pieces.append(
                    (False, f"{f_text}*({inner_text})", rf"{f_tex} \left({inner_tex}\right)")
                )
        text, tex = _joined(pieces)
        depends = [i for i in range(self.n) if mask >> i & 1]
        return Printed(text, tex, error, depends)


def _terms(
    terms: list[tuple[tuple[int, ...], bool, str, str, str]],
) -> list[tuple[bool, str, str]]:
    """(negative, text, LaTeX) of each term: its number (unless 1) and its trigonometric
    factor."""
    out = []
    for _, negative, shown, t_text, t_tex in terms:
        if shown == "1" and t_text:
            out.append((negative, t_text, t_tex))
            continue
        number_tex = latex_number(shown) if "e" in shown else shown
        out.append(
            (
                negative,
                f"{shown}*{t_text}" if t_text else shown,
                f"{number_tex} {t_tex}" if t_tex else number_tex,
            )
        )
    return out


def _joined(pieces: list[tuple[bool, str, str]]) -> tuple[str, str]:
    """A signed sum's text and LaTeX: "a - b + c"."""
    text = "".join(f" - {t}" if neg else f" + {t}" for neg, t, _ in pieces)
    tex = "".join(f" - {t}" if neg else f" + {t}" for neg, _, t in pieces)
    if pieces[0][0]:
        return f"-{text[3:]}", f"- {tex[3:]}"
    return text[3:], tex[3:]
