"""The printed text and LaTeX against the exact series: the text read by SymPy is the series
with its coefficients rounded as asked, the LaTeX says the same, terms below the tolerance are
left out, and the accuracy bound covers what rounding and cutting change."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest
import sympy as sp

from service.dynamics.equations import derive_equations, equations_answer
from service.dynamics.equations.series import Series
from service.dynamics.equations.sympy_form import to_sympy
from service.registry.catalog import load_catalog
from tests.helpers import skewed_arm_urdf

QUANTITIES = [
    "mass_matrix",
    "gravity",
    "coriolis_matrix",
    "christoffel",
    "kinetic_energy",
    "potential_energy",
]


def _flat(value, out):
    if isinstance(value, (str, Series)):
        out.append(value)
    else:
        for v in value:
            _flat(v, out)
    return out


def _names(n: int) -> dict[str, sp.Symbol]:
    names = {f"{p}{i}": sp.Symbol(f"{p}{i}") for p in ("q", "dq") for i in range(1, n + 1)}
    names.update({f"p{i}": sp.Symbol(f"p{i}") for i in range(1, 100)})
    return names


def latex_as_text(tex: str) -> str:
    """The printed LaTeX rewritten, token by token, into text SymPy reads (an independent
    reading of what the LaTeX says)."""
    out = re.sub(r"(\d+(?:\.\d+)?) \\cdot 10\^\{(-?\d+)\}", r"\1e\2", tex)
    out = re.sub(r"(?<![\d.])10\^\{(-?\d+)\}", r"1e\1", out)
    out = re.sub(r"\\dot\{q\}_\{(\d+)\}", r"dq\1", out)
    out = re.sub(r"\\(cos|sin)\{\\left\(", r"\1(", out)
    out = out.replace(r" \right)}", ")").replace(r"\left(", "(").replace(r"\right)", ")")
    out = re.sub(r"\^\{(-?\d+)\}", r"**\1", out)
    out = re.sub(r"_\{(\d+)\}", r"\1", out)
    out = re.sub(r"(?<=[\w)])\s+(?=[\w(])", "*", out)  # juxtaposition is a product
    return out


def _doubles(expr: sp.Expr) -> sp.Expr:
    """The expression with every number replaced by the exact rational of its double."""
    return expr.xreplace({f: sp.Rational(float(f)) for f in expr.atoms(sp.Float)})


def _check(model, digits: int, tolerance: float, quantities=QUANTITIES) -> None:
    eq = derive_equations(model)
    answer = equations_answer(eq, digits, tolerance)
    names = _names(model.nv)
    for quantity in quantities:
        texts = _flat(answer[quantity]["expressions"], [])
        latexes = _flat(answer[quantity]["latex"], [])
        series = _flat(getattr(eq, quantity), [])
        largest = max(float(s.largest_coefficient()) for s in series)
        for text, tex, s in zip(texts, latexes, series, strict=True):
            parsed = sp.sympify(text, locals=names)
            assert parsed.free_symbols <= set(names.values())
            from_latex = sp.sympify(latex_as_text(tex), locals=names)
            assert sp.expand(_doubles(from_latex) - _doubles(parsed)) == 0, tex
            kept = Series(
                s.n,
                {key: c for key, c in s.terms.items() if abs(float(c)) >= tolerance * largest},
            )
            expected = to_sympy(kept)
            if digits >= 17:  # the exact form: the doubles nearest the coefficients
                assert sp.expand(_doubles(parsed) - _doubles(expected)) == 0, text
            else:
                for number in parsed.atoms(sp.Float):
                    mantissa = f"{abs(float(number)):.{digits + 3}e}".split("e")[0]
                    assert len(mantissa.replace(".", "").rstrip("0")) <= digits, text
                difference = sp.expand(_doubles(parsed) - _doubles(expected))
                for coefficient in sp.Add.make_args(difference):
                    size = abs(float(coefficient.as_coeff_Mul()[0]))
                    assert size <= 10 ** (1 - digits) * largest, (text, coefficient)


def test_exact_form_is_the_doubles_of_the_series_for_textbook_and_skewed_arms():
    robots, _ = load_catalog(["planar_arm"])
    _check(robots["planar_arm"].model, 17, 0.0)
    # random placements, axes and full inertia tensors: numbers of every size and sign
    _check(pin.buildModelFromXML(skewed_arm_urdf(2)), 17, 0.0)


@pytest.mark.parametrize(("digits", "tolerance"), [(6, 1e-9), (3, 1e-3), (1, 0.0)])
def test_readable_form_rounds_and_cuts_as_asked(digits, tolerance):
    _check(pin.buildModelFromXML(skewed_arm_urdf(3)), digits, tolerance)


def test_prismatic_coordinates_print_as_powers():
    urdf = skewed_arm_urdf(2).replace('type="revolute"', 'type="prismatic"', 1)
    model = pin.buildModelFromXML(urdf)
    assert model.joints[1].shortname().startswith("JointModelP")
    _check(model, 17, 0.0)
    _check(model, 4, 1e-6)


def test_ur5_exact_mass_matrix_and_gravity_read_back():
    robots, _ = load_catalog(["ur5"])
    _check(robots["ur5"].model, 17, 0.0, ["mass_matrix", "gravity", "potential_energy"])


def test_latex_reading_is_independent():
    """The helper that reads LaTeX back turns a known LaTeX into the known text."""
    tex = r"0.5 - 1.5 \cdot 10^{-12} p_{2} \dot{q}_{1}^{2} \cos{\left(q_{1} + 2 q_{2} \right)}"
    names = _names(2)
    expected = sp.sympify("0.5 - 1.5e-12*p2*dq1**2*cos(q1 + 2*q2)", locals=names)
    assert sp.expand(_doubles(sp.sympify(latex_as_text(tex), locals=names) - expected)) == 0


def test_accuracy_bound_covers_the_printed_form_at_random_states():
    """|printed − exact| ≤ max_abs_error for every entry at random q and unit-bounded q̇."""
    model = pin.buildModelFromXML(skewed_arm_urdf(3))
    eq = derive_equations(model)
    answer = equations_answer(eq, 2, 1e-2)  # coarse: the bound is far from 0
    names = _names(3)
    qs = [names[f"q{i}"] for i in range(1, 4)] + [names[f"dq{i}"] for i in range(1, 4)]
    rng = np.random.default_rng(4)
    for quantity in ["mass_matrix", "gravity", "coriolis_matrix", "kinetic_energy"]:
        bound = answer["accuracy"]["max_abs_error"][quantity]
        texts = _flat(answer[quantity]["expressions"], [])
        series = _flat(getattr(eq, quantity), [])
        worst = 0.0
        for text, s in zip(texts, series, strict=True):
            f = sp.lambdify(qs, sp.sympify(text, locals=names))
            for _ in range(20):
                q, dq = rng.uniform(-np.pi, np.pi, 3), rng.uniform(-1, 1, 3)
                worst = max(worst, abs(float(f(*q, *dq)) - s.evaluate(q, dq)))
        assert 0 < worst <= bound, (quantity, worst, bound)
