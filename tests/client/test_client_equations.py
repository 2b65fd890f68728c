"""The client's `equations`: typed answers from the real app, SymPy objects equal to Pinocchio's
numbers, the structure, the errors, and SymPy as an optional extra."""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
import robodyn
import sympy as sp
from robodyn import AsyncClient, Client

from tests.helpers import random_configuration


def test_planar_arm_equations_are_typed_and_read_back_by_sympy(client: Client) -> None:
    eq = client.equations("planar_arm")
    assert isinstance(eq, robodyn.Equations)
    assert eq.joints == ("shoulder", "elbow") and eq.coordinates == ("q1", "q2")
    assert eq.mass_matrix.expressions[0][0] == "4.235 + 2.1*cos(q2)"
    assert eq.accuracy.digits == 6 and eq.accuracy.tolerance == 1e-9 and eq.parameters == ()
    assert eq.mass_matrix.latex[1][1] == "0.735"
    (_, q2), (dq1, dq2) = eq.symbols()
    M = eq.mass_matrix.sympy(rational=True)
    assert isinstance(M, sp.Matrix) and M.shape == (2, 2)
    l1, l2, m1, m2 = 1, sp.Rational(7, 10), 2, sp.Rational(3, 2)
    assert (
        sp.simplify(M[0, 0] - (m1 * l1**2 + m2 * (l1**2 + l2**2 + 2 * l1 * l2 * sp.cos(q2)))) == 0
    )
    assert eq.gravity.sympy().shape == (2, 1)
    assert eq.christoffel.sympy().shape == (2, 2, 2)
    T = eq.kinetic_energy.sympy(rational=True)
    assert sp.expand(T - (sp.Matrix([[dq1, dq2]]) * M * sp.Matrix([dq1, dq2]))[0] / 2) == 0
    structure = eq.structure
    assert structure.mass_matrix[1][1] == robodyn.EntryStructure((), True, False)
    assert structure.gravity[0].depends_on == ("q1", "q2")


def test_ur5_sympy_objects_equal_pinocchio(client: Client, registry: Any) -> None:
    eq = client.equations("ur5", digits=17, tolerance=0)  # the exact form
    assert eq.accuracy.digits == 17 and eq.accuracy.tolerance == 0
    q, dq = eq.symbols()
    M = sp.lambdify(q, eq.mass_matrix.sympy(), "numpy")
    C = sp.lambdify((*q, *dq), eq.coriolis_matrix.sympy(), "numpy")
    g = sp.lambdify(q, eq.gravity.sympy(), "numpy")
    model = registry.get("ur5").model
    data = model.createData()
    rng = np.random.default_rng(4)
    for _ in range(2):
        qv, v = random_configuration(model, rng), rng.normal(size=6)
        np.testing.assert_allclose(M(*qv), pin.crba(model, data, qv), atol=1e-10)
        np.testing.assert_allclose(
            C(*qv, *v), pin.computeCoriolisMatrix(model, data, qv, v), atol=1e-10
        )
        np.testing.assert_allclose(
            np.ravel(g(*qv)), pin.computeGeneralizedGravity(model, data, qv), atol=1e-9
        )


def test_parametric_form_substitutes_back_to_the_numbers(client: Client, registry: Any) -> None:
    eq = client.equations("planar_arm", form="parametric")
    assert [p.symbol for p in eq.parameters] == [f"p{i}" for i in range(1, 7)]
    assert all(isinstance(p, robodyn.equations.Parameter) for p in eq.parameters)
    M = eq.mass_matrix.sympy()
    values = {sp.Symbol(p.symbol, real=True): p.value for p in eq.parameters}
    (q1, q2), _ = eq.symbols()
    model = registry.get("planar_arm").model
    qv = np.array([0.3, -1.2])
    at = sp.lambdify((q1, q2), M.subs(values), "numpy")
    np.testing.assert_allclose(at(*qv), pin.crba(model, model.createData(), qv), atol=1e-9)


def test_bad_printing_options_are_validation_errors(client: Client) -> None:
    with pytest.raises(robodyn.ValidationError, match="digits"):
        client.equations("planar_arm", digits=0)
    with pytest.raises(robodyn.ValidationError, match="form"):
        client.equations("planar_arm", form="symbolic")


@pytest.mark.parametrize(
    ("robot_id", "error", "says"),
    [
        ("talos", robodyn.UnsupportedModelError, "free-flyer root joint"),
        ("double_pendulum_continuous", robodyn.UnsupportedModelError, "continuous"),
        ("panda", robodyn.UnsupportedModelError, "9 moving joints"),
        ("no_such_robot", robodyn.RobotNotFoundError, "no robot has id"),
    ],
)
def test_errors(client: Client, robot_id: str, error: type, says: str) -> None:
    with pytest.raises(error, match=says) as raised:
        client.equations(robot_id)
    assert isinstance(raised.value, ValueError | LookupError)


@pytest.mark.anyio
async def test_async_client_gives_the_same_answer(aclient: AsyncClient, client: Client) -> None:
    assert await aclient.equations("planar_arm") == client.equations("planar_arm")
    parametric = await aclient.equations("planar_arm", form="parametric", digits=4)
    assert parametric == client.equations("planar_arm", form="parametric", digits=4)
    assert parametric.accuracy.digits == 4 and len(parametric.parameters) == 6
    with pytest.raises(robodyn.UnsupportedModelError):
        await aclient.equations("talos")


def test_sympy_is_an_optional_extra(client: Client, monkeypatch: pytest.MonkeyPatch) -> None:
    eq = client.equations("planar_arm")  # reading the answer needs no SymPy
    monkeypatch.setitem(sys.modules, "sympy", None)  # as if it were not installed
    with pytest.raises(ImportError, match=r"robodyn\[sympy\]"):
        eq.mass_matrix.sympy()
    with pytest.raises(ImportError, match=r"robodyn\[sympy\]"):
        eq.symbols()
