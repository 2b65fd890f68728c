"""The answer's text and LaTeX are SymPy's own: the text read back by `sympify` prints to the
same text, the LaTeX is `sp.latex` of the parsed text, and every number reads back to the double
nearest the derived coefficient."""

from __future__ import annotations

import pinocchio as pin
import sympy as sp

from service.dynamics.equations import derive_equations, equations_answer
from service.dynamics.equations.answer import printed_entry
from service.dynamics.equations.series import Series
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


def _names(n: int) -> tuple[dict[str, sp.Symbol], dict[sp.Symbol, str]]:
    qs = {f"q{i}": sp.Symbol(f"q{i}") for i in range(1, n + 1)}
    dqs = {f"dq{i}": sp.Symbol(f"dq{i}") for i in range(1, n + 1)}
    latex_names = {s: rf"\dot{{q}}_{{{name[2:]}}}" for name, s in dqs.items()}
    return {**qs, **dqs}, latex_names


def _check_round_trip(model, quantities) -> None:
    eq = derive_equations(model)
    answer = _answer(eq, quantities)
    locals_, latex_names = _names(model.nv)
    for quantity in quantities:
        texts = _flat(answer[quantity]["expressions"], [])
        latexes = _flat(answer[quantity]["latex"], [])
        series = _flat(getattr(eq, quantity), [])
        assert len(texts) == len(latexes) == len(series)
        for text, tex, s in zip(texts, latexes, series, strict=True):
            parsed = sp.sympify(text, locals=locals_)
            assert parsed.free_symbols <= set(locals_.values())
            assert sp.sstr(parsed, full_prec=False) == text
            assert sp.latex(parsed, symbol_names=latex_names) == tex
            # numbers: the doubles nearest the derived coefficients, none lost or added (a
            # whole coefficient is an exact integer, 1 is not written)
            derived = {abs(float(c)) for c in s.terms.values()}
            floats = {abs(float(x)) for x in parsed.atoms(sp.Float)}
            assert floats == {x for x in derived if not x.is_integer()}
            integers = {abs(int(x)) for x in parsed.atoms(sp.Integer)} | {1}
            assert {int(x) for x in derived if x.is_integer()} <= integers


def _answer(eq, quantities) -> dict:
    """The service's answer, or for the UR5 (whose whole answer takes seconds to print) the
    same printing of the chosen quantities only."""
    if len(quantities) == len(QUANTITIES):
        return equations_answer(eq)
    return {q: printed_entry(getattr(eq, q), len(eq.joints)) for q in quantities}


def test_text_round_trips_through_sympy_for_textbook_and_skewed_arms():
    robots, _ = load_catalog(["planar_arm"])
    _check_round_trip(robots["planar_arm"].model, QUANTITIES)
    # random placements, axes and full inertia tensors: numbers of every size and sign
    _check_round_trip(pin.buildModelFromXML(skewed_arm_urdf(2)), QUANTITIES)


def test_ur5_mass_matrix_and_gravity_round_trip_through_sympy():
    robots, _ = load_catalog(["ur5"])
    _check_round_trip(robots["ur5"].model, ["mass_matrix", "gravity", "potential_energy"])


def test_prismatic_coordinates_round_trip_through_sympy():
    urdf = skewed_arm_urdf(2).replace('type="revolute"', 'type="prismatic"', 1)
    model = pin.buildModelFromXML(urdf)
    assert model.joints[1].shortname().startswith("JointModelP")
    _check_round_trip(model, QUANTITIES)
