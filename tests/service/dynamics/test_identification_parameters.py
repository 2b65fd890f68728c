"""Inertial parameters, regressor, friction columns and base parameters of identification:
identities against Pinocchio (Y π = RNEA), closed forms (the planar arm's base parameters),
and Pinocchio's own Inertia algebra (pseudo-inertia, change of frame)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.dynamics.identification import (
    LAYOUT,
    body_names,
    inertial_parameters,
    pseudo_inertia,
    regressor,
    with_inertial_parameters,
)
from service.dynamics.identification.base_parameters import base_parameters, random_states_count
from service.dynamics.identification.columns import Columns
from service.dynamics.identification.parameters import (
    body_summary,
    pseudo_inertia_min_eigenvalues,
    transform_parameters,
)
from service.dynamics.identification.pipeline import random_rows
from service.dynamics.identification.regressor import (
    friction_columns,
    friction_torque,
    joint_torque_regressors,
)
from service.registry.catalog import load_catalog
from service.states import prepare
from tests.service.dynamics.identification_logs import configuration

FIXED_BASE = ["ur5", "panda", "planar_arm", "kinova", "double_pendulum"]


@pytest.fixture(scope="module")
def robots():
    loaded, failures = load_catalog(FIXED_BASE)
    assert not failures
    return loaded


def _states(model, rng, count):
    x = rng.uniform(-np.pi, np.pi, (count, model.nv))
    return configuration(model, x), *rng.standard_normal((2, count, model.nv))


@pytest.mark.parametrize("name", FIXED_BASE)
def test_regressor_times_parameters_is_rnea(robots, name):
    robot = robots[name]
    model = robot.model
    rng = np.random.default_rng(7)
    q, v, a = _states(model, rng, 5)
    Y = regressor(robot, q, v, a)
    assert Y.shape == (5, model.nv, 10 * (model.njoints - 1))
    pi = inertial_parameters(model)
    data = model.createData()
    for i in range(5):
        tau = pin.rnea(model, data, q[i], v[i], a[i])
        np.testing.assert_allclose(Y[i] @ pi, tau - model.armature * a[i], atol=1e-9)


def test_the_regressor_of_a_batch_of_states(robots):
    robot = robots["panda"]
    rng = np.random.default_rng(12)
    q, v, a = _states(robot.model, rng, 3)
    states = prepare(robot, {"q": q, "v": v, "a": a}, max_batch=10)
    out = joint_torque_regressors(robot, states)["regressor"]
    np.testing.assert_array_equal(out, regressor(robot, q, v, a))
    single = prepare(robot, {"q": q[1], "v": v[1], "a": a[1]}, max_batch=10)
    np.testing.assert_array_equal(joint_torque_regressors(robot, single)["regressor"][0], out[1])


def test_known_torques_carry_the_armature(robots):
    robot = robots["ur5"]
    model = robot.model.copy()
    model.armature = np.linspace(0.1, 0.6, model.nv)
    geared = type(robot)(
        id="ur5_geared", name="ur5_geared", source="upload", root_joint="fixed", model=model
    )
    rng = np.random.default_rng(8)
    q, v, a = _states(model, rng, 4)
    columns = Columns(geared, "none")
    A, known = columns(q, v, a)
    theta = columns.theta0.copy()
    theta[-model.nv :] = 0.0  # offsets
    data = model.createData()
    for i in range(4):
        np.testing.assert_allclose(
            A[i] @ theta + known[i], pin.rnea(model, data, q[i], v[i], a[i]), atol=1e-9
        )


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_parameters_round_trip_and_pseudo_inertia(robots, name):
    model = robots[name].model
    pi = inertial_parameters(model)
    assert pi.shape == (10 * (model.njoints - 1),)
    assert len(LAYOUT) == 10 and body_names(model) == list(model.names)[1:]
    rebuilt = with_inertial_parameters(model, pi * 1.5)
    np.testing.assert_allclose(inertial_parameters(rebuilt), pi * 1.5, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(inertial_parameters(model), pi)  # the model itself untouched
    for j, block in enumerate(pi.reshape(-1, 10), start=1):
        expected = np.asarray(model.inertias[j].toPseudoInertia().toMatrix())
        np.testing.assert_allclose(pseudo_inertia(block), expected, atol=1e-12)
        summary = body_summary("b", block)
        assert summary["mass"] == pytest.approx(model.inertias[j].mass)
        np.testing.assert_allclose(summary["center_of_mass"], model.inertias[j].lever, atol=1e-12)
        np.testing.assert_allclose(summary["inertia"], model.inertias[j].inertia, atol=1e-12)
    assert (pseudo_inertia_min_eigenvalues(pi) >= -1e-12).all()


def test_a_massless_body_keeps_its_rotational_inertia(robots):
    model = robots["planar_arm"].model
    pi = inertial_parameters(model)
    pi[:10] = [0.0, 0.0, 0.0, 0.0, 0.1, 0.0, 0.2, 0.0, 0.0, 0.3]
    rebuilt = with_inertial_parameters(model, pi)
    np.testing.assert_allclose(inertial_parameters(rebuilt), pi, atol=1e-15)
    assert np.isfinite(pin.crba(rebuilt, rebuilt.createData(), np.zeros(2))).all()


def test_pseudo_inertia_detects_an_impossible_body():
    # principal moments (1, 1, 3) break the triangle inequality: no mass density has them
    block = pin.Inertia(2.0, np.zeros(3), np.diag([1.0, 1.0, 1.0])).toDynamicParameters()
    block[9] = 3.0
    assert pseudo_inertia_min_eigenvalues(block)[0] < 0
    assert pseudo_inertia_min_eigenvalues(-block)[0] < 0  # a negative mass too


def test_change_of_frame_is_pinocchios():
    rng = np.random.default_rng(3)
    placement = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3))
    body = pin.Inertia(1.3, rng.normal(size=3) * 0.1, np.diag([0.02, 0.03, 0.04]))
    np.testing.assert_allclose(
        transform_parameters(placement) @ body.toDynamicParameters(),
        placement.act(body).toDynamicParameters(),
        atol=1e-12,
    )


def test_friction_columns_times_parameters_is_the_friction_torque():
    rng = np.random.default_rng(4)
    v = rng.normal(size=(6, 3))
    v[0, 1] = 0.0  # sign(0) = 0
    coulomb, viscous, offset = rng.uniform(0.1, 1.0, (3, 3))
    phi = np.stack([coulomb, viscous, offset], axis=1).ravel()
    np.testing.assert_allclose(
        friction_columns(v, "coulomb-viscous") @ phi, friction_torque(v, coulomb, viscous, offset)
    )
    np.testing.assert_allclose(
        friction_columns(v, "viscous") @ np.stack([viscous, offset], axis=1).ravel(),
        friction_torque(v, 0 * coulomb, viscous, offset),
    )
    np.testing.assert_allclose(
        friction_columns(v, "none") @ offset, np.broadcast_to(offset, v.shape)
    )


def _base(robot, friction):
    columns = Columns(robot, friction)
    return columns, base_parameters(
        random_rows(robot, columns),
        columns.names,
        random_states_count(len(columns.names), robot.nv),
    )


@pytest.mark.parametrize("name", ["ur5", "kinova", "panda"])
def test_base_parameters_reproduce_every_torque(robots, name):
    """Y_ind (P θ) = [Y | F] θ at fresh random states, for any θ."""
    robot = robots[name]
    columns, base = _base(robot, "coulomb-viscous")
    rng = np.random.default_rng(11)
    q, v, a = _states(robot.model, rng, 20)
    full, _ = columns(q, v, a)
    theta = rng.normal(size=len(columns.names))
    reduced = full[:, :, base.independent]
    np.testing.assert_allclose(
        reduced @ (base.projection() @ theta), full @ theta, atol=1e-8 * np.abs(full @ theta).max()
    )
    assert np.linalg.matrix_rank(reduced.reshape(-1, base.count)) == base.count
    assert len(base.expressions()) == base.count


def test_planar_arm_base_parameters_are_the_textbook_ones(robots):
    """A 2R arm in a vertical plane (axes −y, l1 = 1 m): the six combinations
    h1x + l1 m2, h1z, Iyy1 + l1² m2, h2x, h2z, Iyy2 (plus an offset per joint)."""
    robot = robots["planar_arm"]
    columns, base = _base(robot, "none")
    names = columns.names
    textbook = np.zeros((8, len(names)))
    l1 = 1.0
    for row, terms in enumerate(
        [
            {"shoulder.m_cx": 1.0, "elbow.m": l1},
            {"shoulder.m_cz": 1.0},
            {"shoulder.Iyy": 1.0, "elbow.m": l1**2},
            {"elbow.m_cx": 1.0},
            {"elbow.m_cz": 1.0},
            {"elbow.Iyy": 1.0},
            {"shoulder.offset": 1.0},
            {"elbow.offset": 1.0},
        ]
    ):
        for name, c in terms.items():
            textbook[row, names.index(name)] = c
    projection = base.projection()
    assert base.count == 8
    assert {"shoulder.m_cx + elbow.m", "shoulder.Iyy + elbow.m"} <= set(base.expressions())
    assert np.linalg.matrix_rank(np.vstack([projection, textbook]), tol=1e-9) == 8


def test_inverse_dynamics_adds_an_identified_friction(robots):
    from service.dynamics.equation_of_motion import inverse_dynamics
    from service.errors import InvalidInput
    from service.registry.robot import Robot

    base = robots["ur5"]
    friction = {
        "coulomb": np.linspace(0.5, 1.0, 6),
        "viscous": np.full(6, 0.3),
        "offset": np.linspace(-0.1, 0.1, 6),
    }
    rough = Robot(
        id="ur5_rough",
        name="ur5_rough",
        source="upload",
        root_joint="fixed",
        model=base.model,
        friction=friction,
    )
    rng = np.random.default_rng(5)
    q, v, a = _states(base.model, rng, 4)
    states = prepare(base, {"q": q, "v": v, "a": a}, max_batch=10)
    plain = inverse_dynamics(base, states)["tau"]
    with_friction = inverse_dynamics(rough, states, friction=True)["tau"]
    np.testing.assert_allclose(
        with_friction - plain,
        friction_torque(v, friction["coulomb"], friction["viscous"], friction["offset"]),
        atol=1e-12,
    )
    np.testing.assert_array_equal(inverse_dynamics(rough, states)["tau"], plain)
    with pytest.raises(InvalidInput, match="has no friction model"):
        inverse_dynamics(base, states, friction=True)
    row = rough.info()["friction"][1]
    assert row["joint"] == "shoulder_lift_joint"
    assert (row["coulomb"], row["viscous"], row["offset"]) == pytest.approx((0.6, 0.3, -0.06))
