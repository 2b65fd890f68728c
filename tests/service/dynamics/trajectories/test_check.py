"""The trajectory check against in-process Pinocchio and closed forms: τ at the samples by
RNEA, v and a from the spline (exact for a cubic motion; every boundary against scipy's
CubicSpline of the same bc_type), acceleration peaks, ratios and violations, violations found
between samples, the work against the change of mechanical energy, and the input errors."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.interpolate import CubicSpline

from service.dynamics.trajectories import check_trajectory, evaluation
from service.errors import (
    DimensionMismatch,
    InvalidConfiguration,
    InvalidInput,
    NonFiniteResult,
)
from service.registry import Registry


@pytest.fixture(scope="module")
def robots(tmp_path_factory: pytest.TempPathFactory) -> Registry:
    registry = Registry(
        tmp_path_factory.mktemp("trajectories"),
        ["ur5", "panda", "solo12", "double_pendulum_continuous", "double_pendulum"],
    )
    registry.load()
    return registry


def _motion(
    nq: int, n: int = 41, duration: float = 2.0, seed: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """A smooth motion: t [n], q [n, nq] (sums of sines of moderate speed)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, duration, n)
    amp, freq, phase = rng.uniform(0.2, 0.8, nq), rng.uniform(0.3, 1.0, nq), rng.uniform(0, 6, nq)
    return t, amp * np.sin(freq * t[:, None] * 2 + phase)


def test_tau_at_samples_is_rnea_of_the_spline_derivatives(robots: Registry) -> None:
    robot = robots.get("ur5")
    t, q = _motion(6)
    result = check_trajectory(robot, t, q)
    spline = CubicSpline(t, q, bc_type="not-a-knot")
    v, a = spline(t, 1), spline(t, 2)
    data = robot.model.createData()
    expected = np.array([pin.rnea(robot.model, data, q[i], v[i], a[i]) for i in range(len(t))])
    np.testing.assert_allclose(result.tau, expected, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(result.v, v, rtol=1e-12, atol=1e-12)


def test_given_v_and_a_are_used_as_they_are(robots: Registry) -> None:
    robot = robots.get("ur5")
    rng = np.random.default_rng(1)
    t = np.linspace(0, 1, 7)
    q, v, a = rng.normal(size=(7, 6)), rng.normal(size=(7, 6)), rng.normal(size=(7, 6))
    result = check_trajectory(robot, t, q, v, a)
    data = robot.model.createData()
    expected = np.array([pin.rnea(robot.model, data, q[i], v[i], a[i]) for i in range(7)])
    np.testing.assert_allclose(result.tau, expected, rtol=1e-12, atol=1e-10)
    # known at the samples only: the peaks are those of the samples, no point in between
    for j, joint in enumerate(result.joints):
        assert joint["peak_velocity"] == np.abs(v[:, j]).max()
        assert joint["peak_effort"] == pytest.approx(np.abs(expected[:, j]).max(), rel=1e-12)


def test_cubic_motion_peaks_are_the_closed_form(robots: Registry) -> None:
    """A cubic q(t) is reproduced exactly by the not-a-knot spline: the velocity peak over the
    evaluated points equals the closed form at those points."""
    robot = robots.get("ur5")
    t = np.linspace(0.0, 1.0, 5)
    c = np.array([0.1, -0.4, 1.2, 0.3, -0.2, 0.5])
    q = np.outer(t**3 - 1.5 * t**2, c)  # v = (3t² − 3t) c: peak |v| at t = 0.5
    k = 8
    result = check_trajectory(robot, t, q, samples_per_interval=k)
    t_eval = np.concatenate(
        [np.linspace(t[i], t[i + 1], k, endpoint=False) for i in range(4)] + [t[-1:]]
    )
    # the evaluated points, in chunks of 2 intervals (as a long check is evaluated)
    parts = list(evaluation.chunks(t, q, None, None, evaluation.SampleSpline(t, q), k, 2 * k))
    assert len(parts) == 2 and parts[0].first == 0 and parts[1].first == 2 * k
    np.testing.assert_allclose(np.concatenate([p.t for p in parts]), t_eval, rtol=0, atol=1e-15)
    v_closed = np.outer(3 * t_eval**2 - 3 * t_eval, c)
    v_eval = np.concatenate([p.v for p in parts])
    np.testing.assert_allclose(v_eval, v_closed, rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(np.concatenate([p.q[p.sample_rows] for p in parts]), q)
    for j, joint in enumerate(result.joints):
        assert joint["peak_velocity"] == pytest.approx(0.75 * abs(c[j]), rel=1e-9)
        assert joint["velocity_ratio"] == pytest.approx(
            0.75 * abs(c[j]) / robot.model.velocityLimit[j], rel=1e-9
        )


def test_a_violation_between_samples_is_found(robots: Registry) -> None:
    """At the samples the spline's speed stays under the limit; halfway between two samples it
    exceeds it. With points inside the intervals the check says so, with its time span inside
    that interval; at the samples alone it cannot."""
    robot = robots.get("ur5")
    t = np.arange(6.0)
    q = np.zeros((6, 6))
    q[:, 0] = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0]
    spline = CubicSpline(t, q[:, 0])
    at_samples = np.abs(spline(t, 1)).max()
    between = np.abs(spline(np.linspace(0, 5, 5001), 1)).max()
    assert between > 1.1 * at_samples
    scale = 0.5 * (at_samples + between) / robot.model.velocityLimit[0]
    coarse = check_trajectory(robot, t, q, velocity_scale=scale, samples_per_interval=1)
    assert coarse.feasible
    fine = check_trajectory(robot, t, q, velocity_scale=scale, samples_per_interval=16)
    assert not fine.feasible
    (violation,) = fine.violations
    assert violation["joint"] == "shoulder_pan_joint" and violation["kind"] == "velocity"
    assert 2.0 < violation["t_start"] < 2.5 < violation["t_end"] < 3.0
    assert violation["limit"] == pytest.approx(robot.model.velocityLimit[0] * scale)
    assert abs(violation["worst"]) > violation["limit"]


def test_effort_and_position_violations_with_scales(robots: Registry) -> None:
    robot = robots.get("ur5")
    t, q = _motion(6)
    q[:, 2] += np.linspace(0, 3.3, len(t))  # the elbow leaves [−π, π] near the end
    result = check_trajectory(robot, t, q, effort_scale=0.2)
    g_peak = max(j["peak_effort"] for j in result.joints[1:3])
    assert g_peak > 0.2 * 150  # the shoulder or elbow holds more than 30 N·m
    kinds = {(v["joint"], v["kind"]) for v in result.violations}
    assert ("elbow_joint", "position") in kinds
    assert any(kind == "effort" for _, kind in kinds)
    position = next(v for v in result.violations if v["kind"] == "position")
    assert position["limit"] == pytest.approx(np.pi) and position["t_end"] == t[-1]
    for v in result.violations:
        if v["kind"] == "effort":
            assert abs(v["limit"]) == pytest.approx(30.0) and abs(v["worst"]) > 30.0
    for joint in result.joints:
        assert joint["effort_limit"] == pytest.approx(
            0.2 * robot.model.effortLimit[0]
            if joint["name"].startswith(("sh", "el"))
            else 0.2 * 28.0
        )
        assert joint["effort_ratio"] == pytest.approx(joint["peak_effort"] / joint["effort_limit"])
    elbow = next(j for j in result.joints if j["name"] == "elbow_joint")
    assert elbow["max_position"] > np.pi and elbow["lower"] == pytest.approx(-np.pi)


def test_work_equals_the_change_of_mechanical_energy(robots: Registry) -> None:
    """Without friction, ∫ τᵀv dt = ΔT + ΔV: positive + negative work is the energy change."""
    robot = robots.get("panda")
    t, q = _motion(robot.nq, n=201, duration=2.0, seed=3)
    q[:, 7:] = 0.02  # fingers still
    result = check_trajectory(robot, t, q, samples_per_interval=16)
    model, data = robot.model, robot.model.createData()
    spline = CubicSpline(t, q)

    def energy(i: int) -> float:
        v = spline(t[i], 1)
        return pin.computeKineticEnergy(model, data, q[i], v) + pin.computePotentialEnergy(
            model, data, q[i]
        )

    work = result.work["positive"] + result.work["negative"]
    assert result.work["positive"] > 0 > result.work["negative"]
    assert work == pytest.approx(energy(-1) - energy(0), abs=1e-3 * result.work["positive"])


def test_friction_hook_adds_its_torque(robots: Registry) -> None:
    robot = robots.get("ur5")
    t, q = _motion(6)
    plain = check_trajectory(robot, t, q)
    viscous = np.linspace(1.0, 2.0, 6)
    with_friction = check_trajectory(robot, t, q, friction=lambda v: v * viscous)
    np.testing.assert_allclose(
        with_friction.tau, plain.tau + plain.v * viscous, rtol=1e-12, atol=1e-12
    )


def test_free_flyer_needs_v_and_a(robots: Registry) -> None:
    robot = robots.get("solo12")
    t = np.linspace(0, 1, 3)
    q = np.tile(pin.neutral(robot.model), (3, 1))
    with pytest.raises(InvalidInput, match="v and a are required"):
        check_trajectory(robot, t, q)
    zeros = np.zeros((3, robot.nv))
    result = check_trajectory(robot, t, q, zeros, zeros)
    assert [j["name"] for j in result.joints] == list(robot.joint_types)[1:]  # 1-DoF only
    data = robot.model.createData()
    np.testing.assert_allclose(
        result.tau[0], pin.rnea(robot.model, data, q[0], zeros[0], zeros[0]), atol=1e-10
    )
    bad = q.copy()
    bad[1, 3:7] = [0.0, 0.0, 0.0, 2.0]
    with pytest.raises(InvalidConfiguration):
        check_trajectory(robot, t, bad, zeros, zeros)


def test_continuous_joints_have_no_position(robots: Registry) -> None:
    robot = robots.get("double_pendulum_continuous")
    t = np.linspace(0, 1, 3)
    q = np.tile([1.0, 0.0, 0.0, 1.0], (3, 1))
    zeros = np.zeros((3, 2))
    result = check_trajectory(robot, t, q, zeros, zeros)
    for joint in result.joints:
        assert joint["min_position"] is None and joint["lower"] is None
        assert joint["effort_limit"] is None and joint["effort_ratio"] is None  # URDF's 0
    assert result.feasible


def test_urdf_unset_limits_are_no_limits(robots: Registry) -> None:
    """A URDF <limit> without values gives effort 0, velocity 0 and positions (0, 0): none of
    them is a limit, so nothing is flagged and every ratio is null."""
    robot = robots.get("double_pendulum")
    t = np.linspace(0, 1, 5)
    q = np.outer(t, [2.0, -1.0])
    result = check_trajectory(robot, t, q)
    assert result.feasible
    for joint in result.joints:
        assert joint["lower"] is None and joint["upper"] is None
        assert joint["velocity_ratio"] is None and joint["effort_ratio"] is None
        assert joint["max_position"] > 0 or joint["min_position"] < 0  # positions still given


@pytest.mark.parametrize(
    ("change", "error", "words"),
    [
        (dict(t=[0.0, 1.0, 1.0]), InvalidInput, "t must be strictly increasing: t\\[2\\]"),
        (dict(t=[0.0, np.nan, 2.0]), InvalidInput, "t contains a non-finite"),
        (dict(t=[0.0]), InvalidInput, "t has 1 sample"),
        (dict(q=np.zeros((2, 6))), DimensionMismatch, "q has 2 rows; t has 3"),
        (dict(q=np.zeros((3, 5))), DimensionMismatch, "nq = 6"),
        (dict(v=np.zeros((3, 6, 1))), InvalidInput, "v must be 2-D"),
        (dict(a=np.full((3, 6), np.inf)), InvalidInput, "a contains a non-finite"),
        (dict(effort_scale=0.0), InvalidInput, "effort_scale must be a finite number greater"),
        (dict(velocity_scale=-1.0), InvalidInput, "velocity_scale"),
        (dict(samples_per_interval=0), InvalidInput, "samples_per_interval"),
        (dict(samples_per_interval=65), InvalidInput, "samples_per_interval"),
        (dict(samples_per_interval=True), InvalidInput, "samples_per_interval"),
    ],
)
def test_bad_input_names_the_field(robots: Registry, change: dict, error: type, words: str) -> None:
    args = dict(t=[0.0, 1.0, 2.0], q=np.zeros((3, 6)), v=None, a=None)
    args.update(change)
    t, q, v, a = args.pop("t"), args.pop("q"), args.pop("v"), args.pop("a")
    with pytest.raises(error, match=words):
        check_trajectory(robots.get("ur5"), t, q, v, a, **args)


HELD = np.array([0.0, -1.57, 1.57, 0.0, 0.0, 0.0])


@pytest.mark.parametrize(
    ("t", "step", "between"),
    [
        ([0.0, 5e-324], 0.1, "samples 0 and 1"),  # Δq / Δt = 0.1 / 5e-324 overflows
        ([0.0, 1e-10], 1e300, "samples 0 and 1"),
        ([0.0, 1e-200, 2e-200], 0.1, "samples 0 and 1"),  # the slope fits, q̈ does not
    ],
)
def test_q_changing_faster_than_float64_holds_is_a_422_naming_t_and_q(
    robots: Registry, t: list[float], step: float, between: str
) -> None:
    q = HELD + step * np.arange(len(t))[:, None] * np.ones(6)
    with pytest.raises(InvalidInput, match=f"t and q: between {between}"):
        check_trajectory(robots.get("ur5"), t, q)


def test_a_motion_sampled_1e300_s_apart_is_held_by_gravity(robots: Registry) -> None:
    """Samples 1e300 s apart (and times ±1e308, whose span overflows float64): the spline in
    the unit of its largest interval gives velocities of 1e-301 rad/s, so τ is the gravity
    torque at each sample (Pinocchio's computeGeneralizedGravity)."""
    robot = robots.get("ur5")
    q = HELD + np.outer([0.0, 0.3, -0.2, 0.1], [0.5, 0.4, -0.3, 0.2, 0.1, 0.6])
    data = robot.model.createData()
    gravity = np.array([pin.computeGeneralizedGravity(robot.model, data, row) for row in q])
    for t in (np.arange(4) * 1e300, np.array([-1e308, -1e307, 1e307, 1e308])):
        result = check_trajectory(robot, t, q)
        np.testing.assert_allclose(result.tau, gravity, rtol=1e-12, atol=1e-12)
        assert np.abs(result.v).max() < 1e-290 and np.isfinite(list(result.work.values())).all()


def test_non_finite_torques_work_and_ratios_are_422s_naming_the_input(robots: Registry) -> None:
    """Given v and a of 1e200 (v² overflows in τ); a motion whose power τᵀv integrates beyond
    float64; an effort_scale so small that a peak over its limit overflows."""
    robot = robots.get("ur5")
    t, q = [0.0, 1.0, 2.0], np.array([HELD] * 3)
    huge = np.full((3, 6), 1e200)
    with pytest.raises(NonFiniteResult, match=r"τ at t = 0 s \(sample 0\)"):
        check_trajectory(robot, t, q, huge, huge)
    with pytest.raises(NonFiniteResult, match="the work"):
        check_trajectory(robot, [0.0, 1e300, 2e300], q, np.full((3, 6), 1e10), np.zeros((3, 6)))
    with pytest.raises(InvalidInput, match="effort_scale is too small"):
        check_trajectory(robot, t, q, effort_scale=5e-324)


def _independent_peaks(t, q, bc_type, k):
    """With scipy's own CubicSpline of the same bc_type, the peaks of |v| and |a| over the
    k points per interval the check evaluates: ((N − 1) k + 1 times; v, a there)."""
    spline = CubicSpline(t, q, bc_type=bc_type)
    dense = np.concatenate([np.linspace(t[i], t[i + 1], k + 1)[:-1] for i in range(len(t) - 1)])
    dense = np.append(dense, t[-1])
    return dense, spline(dense, 1), spline(dense, 2)


@pytest.mark.parametrize("boundary", ["not-a-knot", "clamped", "natural"])
def test_acceleration_figures_and_boundaries_equal_an_independent_spline(robots, boundary):
    """Peaks of |v| and |a|, the acceleration limits (null entries: none) and their ratios,
    and τ at the samples, against scipy's CubicSpline with the same bc_type evaluated at the
    same points; each acceleration violation spans exactly the points beyond the limit."""
    robot = robots.get("ur5")
    t, q = _motion(6, n=9, duration=2.0, seed=4)
    limits = [2.0, None, 0.5, None, 3.0, None]
    result = check_trajectory(
        robot, t, q, acceleration=limits, boundary=boundary, samples_per_interval=8
    )
    times, v, a = _independent_peaks(t, q, boundary, 8)
    joints = result.joints
    for j, joint in enumerate(joints):
        assert joint["peak_velocity"] == pytest.approx(np.abs(v[:, j]).max(), rel=1e-9)
        assert joint["peak_acceleration"] == pytest.approx(np.abs(a[:, j]).max(), rel=1e-9)
        assert joint["acceleration_limit"] == limits[j]
        if limits[j] is None:
            assert joint["acceleration_ratio"] is None
        else:
            ratio = np.abs(a[:, j]).max() / limits[j]
            assert joint["acceleration_ratio"] == pytest.approx(ratio, rel=1e-9)
    spline = CubicSpline(t, q, bc_type=boundary)
    data = robot.model.createData()
    tau = [pin.rnea(robot.model, data, q[i], spline(t[i], 1), spline(t[i], 2)) for i in range(9)]
    np.testing.assert_allclose(result.tau, tau, rtol=1e-10, atol=1e-9)
    found = [x for x in result.violations if x["kind"] == "acceleration"]
    for j, limit in enumerate(limits):
        if limit is None:
            assert not [x for x in found if x["joint"] == joints[j]["name"]]
            continue
        over = np.abs(a[:, j]) > limit * (1 + 1e-9)
        mine = [x for x in found if x["joint"] == joints[j]["name"]]
        assert sum(x["t_end"] >= x["t_start"] for x in mine) == len(mine)
        assert bool(mine) == bool(over.any())
        for x in mine:
            inside = (times >= x["t_start"]) & (times <= x["t_end"])
            assert over[inside].all()
            assert abs(x["limit"]) == limit
            assert abs(x["worst"]) == pytest.approx(np.abs(a[inside, j]).max(), rel=1e-9)
    assert result.feasible == (not result.violations)


def test_a_rest_to_rest_motion_through_six_waypoints_in_3_s(robots):
    """Six samples in 3 s of a minimum-jerk motion from rest to rest, the elbow from its lower
    limit −π to 0: with the clamped spline the check starts and ends at zero velocity and
    never leaves the limits, as the motion does (feasible); the not-a-knot spline through the
    same samples moves backwards at both ends (|v| = 0.103 × π / 3 s) and so below −π."""
    robot = robots.get("ur5")
    t = np.linspace(0.0, 3.0, 6)
    tau = t / 3.0
    shape = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    q = np.zeros((6, 6))
    q[:, 1] = -1.0
    lower = float(robot.model.lowerPositionLimit[2])  # −π to 12 digits
    q[:, 2] = lower - lower * shape
    clamped = check_trajectory(robot, t, q, boundary="clamped", samples_per_interval=16)
    assert np.abs(clamped.v[[0, -1]]).max() < 1e-15
    assert clamped.feasible
    assert clamped.joints[2]["min_position"] == lower
    knot = check_trajectory(robot, t, q, samples_per_interval=16)
    np.testing.assert_allclose(knot.v[[0, -1], 2], 0.10346667 * lower, rtol=1e-6)
    below = [x for x in knot.violations if x["kind"] == "position"]
    assert below and below[0]["t_start"] > 0.0 and below[0]["limit"] == lower


def test_bad_acceleration_limits_and_boundary_are_named(robots):
    robot = robots.get("ur5")
    t, q = _motion(6)
    with pytest.raises(DimensionMismatch, match=r"limits\.acceleration has 5 entries"):
        check_trajectory(robot, t, q, acceleration=[1.0] * 5)
    with pytest.raises(InvalidInput, match=r"limits\.acceleration must be finite numbers .* 3"):
        check_trajectory(robot, t, q, acceleration=[1.0, None, 2.0, -1.0, None, 1.0])
    with pytest.raises(InvalidInput, match="boundary must be one of not-a-knot, clamped"):
        check_trajectory(robot, t, q, boundary="periodic")
