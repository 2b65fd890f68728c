"""The derived equations of catalog arms against Pinocchio at random states, the identities
between them (g = ∂U/∂q, Ṁ = C + Cᵀ), their structure, and the scope errors."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import sympy as sp

from service.dynamics.equations import derive_equations, equations_answer
from service.dynamics.equations.series import Series
from service.errors import UnsupportedModel
from service.registry.catalog import load_catalog
from tests.helpers import random_configuration

ARMS = [
    "ur5",
    "ur3",
    "ur10",
    "ur5_gripper",
    "double_pendulum",
    "double_pendulum_simple",
    "asr_twodof",
    "finger_edu",
    "planar_arm",
    "cube_pendulum",
]
RTOL = 1e-10


@pytest.fixture(scope="module")
def arms():
    robots, _ = load_catalog(ARMS)
    return {name: (robots[name].model, derive_equations(robots[name].model)) for name in ARMS}


def _values(entries, q, v=None) -> np.ndarray:
    if isinstance(entries, Series):
        return np.asarray(entries.evaluate(q, v))
    return np.array([_values(e, q, v) for e in entries])


def _close(derived: np.ndarray, reference: np.ndarray) -> None:
    scale = max(1.0, float(np.abs(reference).max()))
    np.testing.assert_allclose(derived, reference, rtol=0, atol=RTOL * scale)


@pytest.mark.parametrize("name", ARMS)
def test_expressions_equal_pinocchio_at_random_states(arms, name):
    model, eq = arms[name]
    data = model.createData()
    rng = np.random.default_rng(7)
    for _ in range(4):
        q = random_configuration(model, rng)
        v = rng.normal(size=model.nv)
        M = pin.crba(model, data, q)
        _close(_values(eq.mass_matrix, q), np.triu(M) + np.triu(M, 1).T)
        _close(_values(eq.gravity, q), pin.computeGeneralizedGravity(model, data, q))
        _close(_values(eq.coriolis_matrix, q, v), pin.computeCoriolisMatrix(model, data, q, v))
        _close(_values(eq.kinetic_energy, q, v), pin.computeKineticEnergy(model, data, q, v))
        _close(_values(eq.potential_energy, q), pin.computePotentialEnergy(model, data, q))


def test_ur5_text_parsed_by_sympy_equals_pinocchio(arms):
    """The exact form's text itself (digits=17, tolerance=0; not the internal form) evaluates
    to Pinocchio's numbers."""
    model, eq = arms["ur5"]
    ans = equations_answer(eq, 17, 0.0)
    n = model.nv
    qs = sp.symbols(f"q1:{n + 1}")
    dqs = sp.symbols(f"dq1:{n + 1}")
    names = {str(s): s for s in (*qs, *dqs)}

    def parse(rows):
        return sp.Matrix([[sp.sympify(e, locals=names) for e in row] for row in rows])

    M = sp.lambdify(qs, parse(ans["mass_matrix"]["expressions"]), "numpy")
    C = sp.lambdify((*qs, *dqs), parse(ans["coriolis_matrix"]["expressions"]), "numpy")
    g = sp.lambdify(qs, parse([ans["gravity"]["expressions"]]), "numpy")
    data = model.createData()
    rng = np.random.default_rng(3)
    for _ in range(3):
        q = random_configuration(model, rng)
        v = rng.normal(size=n)
        _close(np.array(M(*q)), pin.crba(model, data, q))
        _close(np.array(C(*q, *v)), pin.computeCoriolisMatrix(model, data, q, v))
        _close(np.array(g(*q))[0], pin.computeGeneralizedGravity(model, data, q))


@pytest.mark.parametrize("name", ["ur5", "finger_edu", "cube_pendulum"])
def test_identities_hold_between_the_expressions(arms, name):
    """Exactly, as trigonometric polynomials: Ṁ − 2C skew-symmetric (Ṁ = C + Cᵀ), c_ijk =
    c_ikj, M symmetric, g = ∂U/∂q, T = ½ q̇ᵀ M q̇ at random states."""
    model, eq = arms[name]
    n = model.nv
    dq = [Series.variable(n, n + k) for k in range(n)]

    def mdot(i, j):
        out = Series(n)
        for k in range(n):
            out = out + eq.mass_matrix[i][j].derivative(k) * dq[k]
        return out

    for i in range(n):
        for j in range(n):
            assert (eq.mass_matrix[i][j] - eq.mass_matrix[j][i]).is_zero()
            skew = (mdot(i, j) - eq.coriolis_matrix[i][j].scale(2)) + (
                mdot(j, i) - eq.coriolis_matrix[j][i].scale(2)
            )
            assert skew.is_zero()
            for k in range(n):
                assert (eq.christoffel[i][j][k] - eq.christoffel[i][k][j]).is_zero()
        assert (eq.gravity[i] - eq.potential_energy.derivative(i)).is_zero()
    rng = np.random.default_rng(5)
    q, v = random_configuration(model, rng), rng.normal(size=n)
    _close(_values(eq.kinetic_energy, q, v), 0.5 * v @ _values(eq.mass_matrix, q) @ v)


def test_structure_of_the_ur5(arms):
    """Read off the explicit form: M_ij (i ≤ j) never depends on q1 … qi; the first joint's
    axis is vertical, so gravity does not act on it; the last entry of M is the last body's
    constant inertia about its axis."""
    model, eq = arms["ur5"]
    ans = equations_answer(eq)
    structure = ans["structure"]
    for i in range(6):
        for j in range(i, 6):
            depends = structure["mass_matrix"][i][j]["depends_on"]
            assert all(int(name[1:]) > i + 1 for name in depends), (i, j, depends)
            assert structure["mass_matrix"][j][i] == structure["mass_matrix"][i][j]
    assert structure["gravity"][0] == {"depends_on": [], "constant": True, "zero": True}
    assert ans["gravity"]["expressions"][0] == "0"
    # the wrist bodies' centres of mass lie on the wrist 2 and 3 axes: no gravity torque there
    assert structure["gravity"][4]["zero"] and structure["gravity"][5]["zero"]
    assert structure["gravity"][1]["depends_on"] == ["q2", "q3", "q4"]
    last = structure["mass_matrix"][5][5]
    assert last["constant"] and not last["zero"]
    # wrist 3's inertia about its axis (y): constant, and what crba gives at any q
    exact = equations_answer(eq, 17, 0.0)
    assert float(exact["mass_matrix"]["expressions"][5][5]) == pytest.approx(
        pin.crba(model, model.createData(), pin.neutral(model))[5, 5], rel=1e-15
    )
    assert ans["joints"] == [model.names[j] for j in range(1, model.njoints)]
    assert np.shape(ans["christoffel"]["expressions"]) == (6, 6, 6)
    assert np.shape(ans["christoffel"]["latex"]) == (6, 6, 6)
    assert isinstance(ans["kinetic_energy"]["expressions"], str)


@pytest.mark.parametrize("name", ["ur5", "finger_edu"])
def test_structure_agrees_with_pinocchio(arms, name):
    """An entry of M or g changes with a coordinate (at random states, in Pinocchio's numbers)
    exactly when the structure lists that coordinate; zero entries are zero in Pinocchio."""
    model, eq = arms[name]
    structure = equations_answer(eq)["structure"]
    data = model.createData()
    n = model.nv
    rng = np.random.default_rng(11)
    q = random_configuration(model, rng)
    M0, g0 = pin.crba(model, data, q).copy(), pin.computeGeneralizedGravity(model, data, q).copy()
    moved = {}
    for k in range(n):
        dq = q.copy()
        dq[k] += 0.3
        moved[k] = (
            pin.crba(model, data, dq).copy(),
            pin.computeGeneralizedGravity(model, data, dq).copy(),
        )
    tol = 1e-9
    for i in range(n):
        for j in range(i, n):
            entry = structure["mass_matrix"][i][j]
            assert entry["zero"] == (abs(M0[i, j]) < tol)
            changes = [f"q{k + 1}" for k in range(n) if abs(moved[k][0][i, j] - M0[i, j]) > tol]
            assert changes == entry["depends_on"], (i, j)
        entry = structure["gravity"][i]
        assert entry["zero"] == (abs(g0[i]) < tol)
        changes = [f"q{k + 1}" for k in range(n) if abs(moved[k][1][i] - g0[i]) > tol]
        assert changes == entry["depends_on"], i


def test_numbers_are_written_to_round_trip_precision(arms):
    """Every coefficient of the exact form's text reads back to the double nearest the derived
    value."""
    _, eq = arms["ur5"]
    text = equations_answer(eq, 17, 0.0)["mass_matrix"]["expressions"][0][0]
    numbers = {abs(float(x)) for x in sp.sympify(text).atoms(sp.Float)}
    derived = {abs(float(c)) for c in eq.mass_matrix[0][0].terms.values()}
    assert numbers == derived and len(derived) > 10


def _urdf_chain(count: int, kind: str = "revolute") -> str:
    links = "".join(
        f'<link name="l{i}"><inertial><origin xyz="0.1 0 0"/><mass value="1"/>'
        f'<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>'
        for i in range(1, count + 1)
    )
    joints = "".join(
        f'<joint name="j{i}" type="{kind}"><parent link="l{i - 1}"/><child link="l{i}"/>'
        f'<origin xyz="0.2 0 0"/><axis xyz="0 0 1"/>'
        f'<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
        for i in range(1, count + 1)
    )
    return f'<robot name="chain"><link name="l0"/>{links}{joints}</robot>'


def test_out_of_scope_models_are_unsupported_saying_which():
    chain = _urdf_chain(2)
    with pytest.raises(UnsupportedModel, match="free-flyer root"):
        derive_equations(pin.buildModelFromXML(chain, pin.JointModelFreeFlyer()))
    with pytest.raises(UnsupportedModel, match="planar root"):
        derive_equations(pin.buildModelFromXML(chain, pin.JointModelPlanar()))
    with pytest.raises(UnsupportedModel, match="'j1' is continuous"):
        derive_equations(pin.buildModelFromXML(_urdf_chain(2, "continuous")))
    with pytest.raises(UnsupportedModel, match=r"7 moving joints; .* at most 6"):
        derive_equations(pin.buildModelFromXML(_urdf_chain(7)))
    ball = pin.Model()
    jid = ball.addJoint(0, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    ball.appendBodyToJoint(jid, pin.Inertia.FromSphere(1.0, 0.1), pin.SE3.Identity())
    with pytest.raises(UnsupportedModel, match="'ball' is of type spherical"):
        derive_equations(ball)
    with pytest.raises(UnsupportedModel, match="no moving joint"):
        derive_equations(pin.Model())
    assert len(derive_equations(pin.buildModelFromXML(_urdf_chain(6))).joints) == 6


def test_a_derivation_past_its_time_limit_is_unsupported(arms):
    model, _ = arms["ur5"]
    with pytest.raises(UnsupportedModel, match="time limit of 1e-06 s"):
        derive_equations(model, time_limit_s=1e-6)


def test_ur5_derives_well_within_its_budget(arms):
    """The UR5 must derive cold within 60 s on a 2-core machine; it takes well under a second
    (bench/equations.py measures it)."""
    model, _ = arms["ur5"]
    assert derive_equations(model).seconds < 10


def _random_tree_urdf(kinds: str, parents: list[int], seed: int) -> str:
    """Joints of `kinds` ("r" revolute, "p" prismatic), joint i attached to link parents[i]
    (0 = the base), with random placements, rpy, unit axes, centres of mass and full inertias."""
    rng = np.random.default_rng(seed)
    links, joints = ['<link name="l0"/>'], []
    for i, (kind, parent) in enumerate(zip(kinds, parents, strict=True), start=1):
        ii = rng.uniform(0.01, 0.1, 3)
        c, rpy = rng.uniform(-0.2, 0.2, 3), rng.uniform(-1, 1, 3)
        links.append(
            f'<link name="l{i}"><inertial><origin xyz="{c[0]} {c[1]} {c[2]}" '
            f'rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/><mass value="{rng.uniform(0.5, 3)}"/>'
            f'<inertia ixx="{ii[0]}" ixy="0.001" ixz="-0.002" iyy="{ii[1]}" iyz="0.003" '
            f'izz="{ii[2]}"/></inertial></link>'
        )
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        p, rpy = rng.uniform(-0.3, 0.3, 3), rng.uniform(-2, 2, 3)
        joints.append(
            f'<joint name="j{i}" type="{"revolute" if kind == "r" else "prismatic"}">'
            f'<parent link="l{parent}"/><child link="l{i}"/>'
            f'<origin xyz="{p[0]} {p[1]} {p[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/>'
            f'<axis xyz="{axis[0]} {axis[1]} {axis[2]}"/>'
            f'<limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
        )
    return f'<robot name="tree">{"".join(links + joints)}</robot>'


@pytest.mark.parametrize(
    ("kinds", "parents"),
    [
        ("rpr", [0, 1, 2]),  # a slider between two skewed hinges
        ("prp", [0, 1, 2]),
        ("rrpr", [0, 1, 1, 3]),  # a branching tree: two limbs on link 1
        ("rr", [0, 0]),  # two limbs on the base
    ],
)
def test_skewed_trees_with_sliders_equal_pinocchio(kinds, parents):
    model = pin.buildModelFromXML(_random_tree_urdf(kinds, parents, seed=len(kinds)))
    model.armature = np.linspace(0.01, 0.05, model.nv)  # added to M's diagonal, as crba does
    eq = derive_equations(model)
    data = model.createData()
    rng = np.random.default_rng(2)
    for _ in range(3):
        q = random_configuration(model, rng)
        v = rng.normal(size=model.nv)
        _close(_values(eq.mass_matrix, q), pin.crba(model, data, q))
        _close(_values(eq.gravity, q), pin.computeGeneralizedGravity(model, data, q))
        _close(_values(eq.coriolis_matrix, q, v), pin.computeCoriolisMatrix(model, data, q, v))
        # T = ½ vᵀ M v with M from crba: Pinocchio 4.1's computeKineticEnergy leaves out the
        # armature of revolute joints with an unaligned axis (it keeps the others')
        _close(_values(eq.kinetic_energy, q, v), 0.5 * v @ pin.crba(model, data, q) @ v)
        _close(_values(eq.potential_energy, q), pin.computePotentialEnergy(model, data, q))
    if parents == [0, 0]:  # two limbs on the base do not couple
        assert eq.mass_matrix[0][1].is_zero() and eq.coriolis_matrix[0][1].is_zero()
