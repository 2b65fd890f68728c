"""The algebra of exact trigonometric polynomials: products, derivatives and the canonical form
against numbers, and their printed text and LaTeX."""

from __future__ import annotations

import math
from decimal import Decimal

import numpy as np
import pytest
import sympy as sp

from service.dynamics.equations.printing import Printer
from service.dynamics.equations.series import COS, SIN, Series, pack, unpack
from service.dynamics.equations.sympy_form import symbols

N = 3


def render(series: Series) -> str:
    """The exact form's text (17 digits, every term)."""
    return Printer(series.n, 17).entry(series, 0.0).text


def render_latex(series: Series) -> str:
    return Printer(series.n, 17).entry(series, 0.0).latex


def _random_series(rng: np.random.Generator, terms: int = 4) -> Series:
    """A sum of random products of cos/sin of the coordinates, q3 (prismatic) and dq's."""
    out = Series(N)
    for _ in range(terms):
        term = Series.constant(N, Decimal(str(round(float(rng.normal()), 6))))
        for _ in range(rng.integers(0, 4)):
            i = int(rng.integers(0, 2))
            term = term * Series.trig(N, i, int(rng.integers(0, 2)))
        if rng.random() < 0.5:
            term = term * Series.variable(N, 2)  # q3
        if rng.random() < 0.5:
            term = term * Series.variable(N, N + int(rng.integers(0, N)))
        out = out + term
    return out


@pytest.mark.parametrize("seed", range(5))
def test_products_sums_and_derivatives_match_numbers(seed):
    rng = np.random.default_rng(seed)
    a, b = _random_series(rng), _random_series(rng)
    for _ in range(3):
        q, dq = rng.uniform(-3, 3, N), rng.normal(size=N)
        va, vb = a.evaluate(q, dq), b.evaluate(q, dq)
        assert (a * b).evaluate(q, dq) == pytest.approx(va * vb, abs=1e-12)
        assert (a - b).evaluate(q, dq) == pytest.approx(va - vb, abs=1e-12)
        for i in range(2 * N):
            h = 1e-6
            x = np.concatenate([q, dq])
            xp, xm = x.copy(), x.copy()
            xp[i] += h
            xm[i] -= h
            numeric = (a.evaluate(xp[:N], xp[N:]) - a.evaluate(xm[:N], xm[N:])) / (2 * h)
            assert a.derivative(i).evaluate(q, dq) == pytest.approx(numeric, abs=1e-6)


def test_canonical_form_collects_equal_expressions():
    c1, s1 = Series.trig(2, 0, COS), Series.trig(2, 0, SIN)
    c2, s2 = Series.trig(2, 1, COS), Series.trig(2, 1, SIN)
    # cos²q1 + sin²q1 = 1, exactly: one constant term
    one = c1 * c1 + s1 * s1
    assert one.constant_value() == 1
    # cos(q1 + q2) = c1 c2 − s1 s2 is one term, written as a sum of angles
    c12 = c1 * c2 - s1 * s2
    assert len(c12.terms) == 1 and render(c12) == "cos(q1 + q2)"
    # sin(q1 − q2) = s1 c2 − c1 s2
    assert render(s1 * c2 - c1 * s2) == "sin(q1 - q2)"
    assert render(s2 * c1 - c2 * s1) == "-sin(q1 - q2)"
    assert (c12 - (c2 * c1 - s2 * s1)).is_zero()
    # sin² q2 = ½ − ½ cos 2q2
    assert render(s2 * s2) == "0.5 - 0.5*cos(2*q2)"
    assert render_latex(s2 * s2) == r"0.5 - 0.5 \cos{\left(2 q_{2} \right)}"


def test_text_layout_and_numbers():
    n = 2
    dq1, dq2 = Series.variable(n, 2), Series.variable(n, 3)
    s2 = Series.trig(n, 1, SIN)
    expr = (
        (dq1 * s2).scale(Decimal("-1.05"))
        + (dq2 * dq2).scale(Decimal("0.3675"))
        + (dq1 * (Series.constant(n, Decimal("2")) + Series.trig(n, 1, COS)))
    )
    # grouped by the monomial in the velocities, the constant first, then by coordinate; a
    # whole coefficient is an integer, a coefficient 1 not written
    assert render(expr) == "dq1*(2 + cos(q2) - 1.05*sin(q2)) + 0.3675*dq2**2"
    assert render_latex(expr) == (
        r"\dot{q}_{1} \left(2 + \cos{\left(q_{2} \right)} - 1.05 \sin{\left(q_{2} \right)}\right)"
        r" + 0.3675 \dot{q}_{2}^{2}"
    )
    tiny = Series.constant(n, Decimal("1.5e-12")) * s2
    assert render(tiny) == "1.5e-12*sin(q2)"
    assert render_latex(tiny) == r"1.5 \cdot 10^{-12} \sin{\left(q_{2} \right)}"
    assert render(Series(n)) == "0"
    # a coefficient beyond double precision is written as the nearest double, round trip
    third = Series.constant(n, Decimal(1) / Decimal(3))
    assert float(render(third)) == 1 / 3 and render(third) == repr(1 / 3)
    q1, q2, d1, d2 = sp.symbols("q1 q2 dq1 dq2")
    parsed = sp.sympify(render(expr), locals=symbols(n))
    x = {q1: 0.3, q2: -1.1, d1: 0.7, d2: 2.0}
    assert float(parsed.subs(x)) == pytest.approx(expr.evaluate([0.3, -1.1], [0.7, 2.0]))


def test_packed_vectors_round_trip():
    rng = np.random.default_rng(0)
    for size in (1, 3, 6, 12):
        for _ in range(20):
            digits = tuple(int(x) for x in rng.integers(-40, 41, size))
            packed = pack(digits)
            assert unpack(packed, size) == digits
            first = next((d for d in digits if d), 0)
            assert math.copysign(1, packed) == math.copysign(1, first) or packed == first == 0
