"""Identification on synthetic truth: a catalog arm perturbed physically consistently, excited
by Fourier series, with friction and noise (tests/service/dynamics/identification_logs.py).
The fit must predict held-out torques at the noise level, recover the base parameters within
their standard deviations and the friction within 10 %, produce positive semidefinite
pseudo-inertias, and find a payload's mass within 2 % and centre of mass within 5 mm."""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin
import pytest

from service.dynamics.identification import identify
from service.dynamics.identification.base_parameters import base_parameters, random_states_count
from service.dynamics.identification.columns import Columns
from service.dynamics.identification.fit import CONSISTENCY_TOLERANCE
from service.dynamics.identification.pipeline import random_rows
from service.errors import InvalidInput
from service.registry.catalog import load_catalog
from service.registry.reduce import reduced_robot
from service.registry.robot import Robot
from tests.service.dynamics.identification_logs import loaded_parameters, synthetic_log


@pytest.fixture(scope="module")
def robots():
    loaded, failures = load_catalog(["ur5", "panda", "kinova"])
    assert not failures
    panda = loaded["panda"]
    locked = {"panda_finger_joint1": [0.02], "panda_finger_joint2": [0.02]}
    loaded["panda_arm"] = reduced_robot(
        panda, locked, "panda_arm", "panda_arm", {"robot": "panda", "locked_joints": locked}
    )
    return loaded


def _true_base(robot, log, friction="coulomb-viscous"):
    columns = Columns(robot, friction)
    base = base_parameters(
        random_rows(robot, columns),
        columns.names,
        random_states_count(len(columns.names), robot.nv),
    )
    theta = np.concatenate([log.pi, np.stack([log.coulomb, log.viscous, log.offset], 1).ravel()])
    return base.projection() @ theta


def _check_friction(result, log):
    coulomb = np.array([f["coulomb"] for f in result.friction])
    viscous = np.array([f["viscous"] for f in result.friction])
    np.testing.assert_allclose(coulomb, log.coulomb, rtol=0.1)
    np.testing.assert_allclose(viscous, log.viscous, rtol=0.1)


def _check_base(result, truth, worst=4.0, typical=1.6):
    z = (result.base_parameters["values"] - truth) / result.base_parameters["standard_deviation"]
    assert np.abs(z).max() < worst, np.abs(z).max()
    assert np.sqrt(np.mean(z**2)) < typical  # the standard deviations are honest


def test_least_squares_with_measured_velocities(robots):
    robot = robots["ur5"]
    log = synthetic_log(robot.model, seed=1, duration=20.0, rate=200.0, noise=0.05)
    result = identify(robot, log.t, log.q, log.tau, v=log.v, a=log.a, method="least-squares")
    assert result.filter_hz is None
    # held-out torques at the noise level; the catalog's own model is far off
    assert (result.rmse["validation"] < 1.15 * log.noise).all()
    assert (result.rmse["train"] < 1.15 * log.noise).all()
    assert (result.rmse["validation_before"] > 10 * log.noise).any()
    _check_base(result, _true_base(robot, log))
    _check_friction(result, log)
    assert result.samples["validation"] == pytest.approx(0.2 * log.t.size, abs=2)


def test_noiseless_log_recovers_the_base_parameters_exactly(robots):
    robot = robots["ur5"]
    log = synthetic_log(robot.model, seed=2, duration=10.0, rate=100.0, noise=0.0)
    result = identify(robot, log.t, log.q, log.tau, v=log.v, a=log.a, method="least-squares")
    truth = _true_base(robot, log)
    np.testing.assert_allclose(
        result.base_parameters["values"], truth, atol=1e-7 * np.abs(truth).max()
    )
    assert (result.rmse["validation"] < 1e-7).all()


@pytest.mark.parametrize("scale", [1.0, 1000.0])
def test_a_noiseless_consistent_fit_recovers_the_truth_at_any_torque_scale(robots, scale):
    """The same motion of a robot whose every inertia (and friction) is `scale` times the
    UR5's: τ scales with it, and the physically consistent fit, whose prior's weight does not
    depend on the torques' units, recovers the true base parameters to 1e-6 at both scales."""
    base = robots["ur5"]
    model = base.model.copy()
    for j in range(1, model.njoints):
        model.inertias[j] = pin.Inertia.FromDynamicParameters(
            scale * model.inertias[j].toDynamicParameters()
        )
    robot = Robot(
        id="ur5_scaled", name="ur5_scaled", source="upload", root_joint="fixed", model=model
    )
    log = synthetic_log(base.model, seed=2, duration=10.0, rate=100.0, noise=0.0)
    log.tau, log.pi = scale * log.tau, scale * log.pi
    log.coulomb, log.viscous, log.offset = (
        scale * x for x in (log.coulomb, log.viscous, log.offset)
    )
    result = identify(robot, log.t, log.q, log.tau, v=log.v, a=log.a)
    assert result.physically_consistent and not result.warnings
    truth = _true_base(robot, log)
    error = np.abs(result.base_parameters["values"] - truth)
    assert error.max() <= 1e-6 * np.abs(truth).max(), error.max() / np.abs(truth).max()


def test_physically_consistent_fit_of_a_filtered_irregular_log(robots):
    """q and τ only, jittered sample times: resampled, filtered, differentiated."""
    robot = robots["ur5"]
    log = synthetic_log(robot.model, seed=5, duration=20.0, rate=200.0, noise=0.05, irregular=True)
    result = identify(robot, log.t, log.q, log.tau)
    assert result.filter_hz == 10.0
    assert result.physically_consistent
    eigenvalues = [b["pseudo_inertia_min_eigenvalue"] for b in result.bodies]
    assert min(eigenvalues) >= -CONSISTENCY_TOLERANCE
    # filtered torques: the prediction error is below the (unfiltered) noise level
    assert (result.rmse["validation"] < log.noise).all()
    assert (result.rmse["validation"] < 0.05 * result.rmse["validation_before"]).all()
    _check_base(result, _true_base(robot, log), worst=4.5, typical=2.0)
    _check_friction(result, log)
    # the identified model predicts what Pinocchio computes for the true one
    model = robot.model.copy()
    for j, body in enumerate(result.bodies, start=1):
        model.inertias[j] = pin.Inertia(body["mass"], body["center_of_mass"], body["inertia"])
    true = robot.model.copy()
    for j, block in enumerate(log.pi.reshape(-1, 10), start=1):
        true.inertias[j] = pin.Inertia.FromDynamicParameters(block)
    data, true_data = model.createData(), true.createData()
    for i in range(0, log.t.size, 500):
        tau = pin.rnea(model, data, log.q[i], log.v[i], log.a[i])
        expected = pin.rnea(true, true_data, log.q[i], log.v[i], log.a[i])
        np.testing.assert_allclose(tau, expected, atol=0.05)


def test_least_squares_is_not_constrained_but_reports_its_eigenvalues(robots):
    robot = robots["ur5"]
    log = synthetic_log(robot.model, seed=1, duration=20.0, rate=200.0, noise=0.05)
    result = identify(robot, log.t, log.q, log.tau, method="least-squares")
    eigenvalues = np.array([b["pseudo_inertia_min_eigenvalue"] for b in result.bodies])
    assert result.physically_consistent == bool((eigenvalues >= -CONSISTENCY_TOLERANCE).all())
    consistent = identify(robot, log.t, log.q, log.tau)
    assert consistent.physically_consistent
    # the constraint costs almost nothing in prediction
    assert (consistent.rmse["validation"] < 1.1 * result.rmse["validation"] + 1e-3).all()


def test_ordinary_and_weighted_least_squares(robots):
    """Joints with noise levels 0.01 to 0.5 N·m: ordinary least squares is the plain solution
    of the stacked rows; the weighted fit's standard deviations are smaller, and honest."""
    robot = robots["ur5"]
    log = synthetic_log(robot.model, seed=8, duration=20.0, rate=200.0, noise=0.0)
    levels = np.array([0.01, 0.5, 0.02, 0.3, 0.01, 0.05])
    log.tau += np.random.default_rng(9).normal(size=log.tau.shape) * levels
    inputs = {
        "t": log.t,
        "q": log.q,
        "tau": log.tau,
        "v": log.v,
        "a": log.a,
        "method": "least-squares",
    }
    ordinary = identify(robot, weighted=False, **inputs)
    weighted = identify(robot, **inputs)
    columns = Columns(robot, "coulomb-viscous")
    base = base_parameters(
        random_rows(robot, columns),
        columns.names,
        random_states_count(len(columns.names), robot.nv),
    )
    train = log.t < log.t[0] + 0.8 * (log.t[-1] - log.t[0])
    A, known = columns(log.q[train], log.v[train], log.a[train], base.independent)
    plain = np.linalg.lstsq(
        A.reshape(-1, base.count), (log.tau[train] - known).ravel(), rcond=None
    )[0]
    np.testing.assert_allclose(
        ordinary.base_parameters["values"], plain, atol=1e-8 * np.abs(plain).max()
    )
    std_ratio = (
        weighted.base_parameters["standard_deviation"]
        / ordinary.base_parameters["standard_deviation"]
    )
    assert np.median(std_ratio) < 0.7
    _check_base(weighted, _true_base(robot, log))
    np.testing.assert_allclose(weighted.rmse["validation"], levels, rtol=0.15)


def test_a_joint_that_never_moves(robots):
    """wrist_3 held still: least squares refuses the log; the consistent fit keeps what the log
    cannot tell at the model's values, reports no finite condition number, and spreads the
    standard deviations of what it cannot tell over the prior."""
    robot = robots["ur5"]
    log = synthetic_log(robot.model, seed=1, duration=20.0, rate=200.0, noise=0.05)
    model = robot.model
    still = log.q.copy()
    still[:, 5] = 0.3
    v, a = log.v.copy(), log.a.copy()
    v[:, 5] = a[:, 5] = 0.0
    true = model.copy()
    for j, block in enumerate(log.pi.reshape(-1, 10), start=1):
        true.inertias[j] = pin.Inertia.FromDynamicParameters(block)
    data = true.createData()
    rng = np.random.default_rng(3)
    tau = np.array([pin.rnea(true, data, still[i], v[i], a[i]) for i in range(log.t.size)])
    tau += log.offset + log.coulomb * np.sign(v) + log.viscous * v
    tau += rng.normal(0.0, log.noise, tau.shape)
    with pytest.raises(InvalidInput, match="does not excite"):
        identify(robot, log.t, still, tau, v=v, a=a, method="least-squares")
    result = identify(robot, log.t, still, tau, v=v, a=a)
    assert result.condition_number == np.inf
    assert result.physically_consistent
    assert np.isfinite(result.base_parameters["standard_deviation"]).all()
    assert (result.rmse["validation"] < 1.2 * log.noise).all()
    # its friction columns are fitted, but the log cannot tell their values: not reported
    assert result.friction[5] is None and all(f is not None for f in result.friction[:5])
    assert [w["joint"] for w in result.warnings] == ["wrist_3_joint"]


@pytest.mark.parametrize("friction", ["none", "viscous"])
def test_simpler_friction_models(robots, friction):
    robot = robots["ur5"]
    log = synthetic_log(robot.model, seed=6, duration=20.0, rate=200.0, noise=0.05, friction=False)
    log.tau += log.offset + (0.5 * log.v if friction == "viscous" else 0.0)
    result = identify(
        robot, log.t, log.q, log.tau, v=log.v, a=log.a, friction=friction, method="least-squares"
    )
    assert all(f["coulomb"] == 0.0 for f in result.friction)
    viscous = np.array([f["viscous"] for f in result.friction])
    np.testing.assert_allclose(viscous, 0.5 if friction == "viscous" else 0.0, atol=0.05)
    assert (result.rmse["validation"] < 1.15 * log.noise).all()


def test_continuous_joints(robots):
    """kinova: three continuous joints ((cos, sin) in q), unwrapped before filtering."""
    robot = robots["kinova"]
    assert robot.nq > robot.nv
    log = synthetic_log(robot.model, seed=7, duration=20.0, rate=200.0, noise=0.02)
    result = identify(robot, log.t, log.q, log.tau)
    assert result.physically_consistent
    assert (result.rmse["validation"] < log.noise).all()
    _check_friction(result, log)


def test_payload_identification(robots):
    """A 1.5 kg payload at the panda's hand; everything else is the catalog model."""
    robot = robots["panda_arm"]
    payload = pin.Inertia(1.5, np.array([0.01, -0.02, 0.08]), np.diag([0.004, 0.005, 0.003]))
    log = synthetic_log(
        robot.model,
        seed=4,
        duration=20.0,
        rate=500.0,
        noise=0.05,
        pi=loaded_parameters(robot.model, "panda_hand", payload),
    )
    result = identify(robot, log.t, log.q, log.tau, payload_frame="panda_hand")
    found = result.payload
    assert found is not None and found["frame"] == "panda_hand"
    assert found["mass"] == pytest.approx(1.5, rel=0.02)
    assert np.linalg.norm(found["center_of_mass"] - payload.lever) < 0.005
    assert np.linalg.eigvalsh(found["inertia"]).min() >= -1e-9  # usable as a payload
    assert result.base_parameters["expressions"][0] == "payload.m"
    _check_friction(result, log)
    # the robot's parameters: the model's, with the payload on the hand's body
    np.testing.assert_allclose(result.parameters[:60], log.pi[:60])
    assert result.parameters[60] == pytest.approx(log.pi[60], rel=0.02)


@pytest.mark.slow
def test_a_20000_sample_log_of_a_7_dof_arm_within_a_minute(robots):
    robot = robots["panda_arm"]
    log = synthetic_log(robot.model, seed=3, duration=20.0, rate=1000.0, noise=0.05)
    start = time.perf_counter()
    result = identify(robot, log.t, log.q, log.tau)
    assert time.perf_counter() - start < 60.0
    assert result.physically_consistent
    assert (result.rmse["validation"] < log.noise).all()
