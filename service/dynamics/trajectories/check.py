"""Does a sampled joint trajectory stay within the robot's limits?

Input: samples at times t [N] (s, strictly increasing, N ≥ 2) of q [N, nq], and optionally v and
a [N, nv]. Where v and a are absent they are the derivatives of the cubic spline through (t, q)
with the `boundary` conditions asked for (`evaluation.SampleSpline`: not-a-knot, clamped or
natural; robots with nq = nv only), and the check also
evaluates k − 1 evenly spaced points inside every interval (k = `samples_per_interval`), so that
a limit broken between two samples is found. Where v and a are given, the motion is known at the
samples only and is evaluated there.

At every evaluated point: τ = M(q) a + C(q, v) v + g(q) (+ friction(v) where a friction model
is given) and the wrench each 1-DoF joint transmits, by RNEA state by state (its `data.f`: the
same pass). Answer: τ at the samples, per 1-DoF joint the peaks of |τ|, |v| and |a|, the
extremes of q and their ratios to the limits (acceleration limits where the request gives
them; `summary.MotionSummary`), its RMS effort, peak power and peak loads
(`loads.JointLoadPeaks`), the violations with their time spans, and the work: the integrals
over time of max(τᵀv, 0) (positive, J) and min(τᵀv, 0) (negative, J) by the trapezoidal rule
over the evaluated points.

Cost: the evaluated points × nv (`check_work`), refused over `max_work` before anything is
computed (`admit_check`: the service's ROBODYN_MAX_TRAJECTORY_WORK). The points are evaluated
in chunks of about CHUNK_NUMBERS points × nv (`evaluation.chunks`), so a check holds its samples
(q, the spline's four coefficients, v and τ there: about 56 bytes a sample × nv) and one chunk,
never all of its points: at most about 56 bytes a unit of work.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from service.dynamics.stopping import ShouldStop, Stopper
from service.dynamics.trajectories.evaluation import (
    BOUNDARIES,
    SampleSpline,
    chunks,
    evaluated_points,
)
from service.dynamics.trajectories.inputs import (
    acceleration_limits,
    positive,
    sample_times,
    samples,
)
from service.dynamics.trajectories.loads import JointLoadPeaks, inverse_dynamics_with_loads
from service.dynamics.trajectories.summary import MotionSummary
from service.errors import InvalidInput, NonFiniteResult
from service.registry.robot import Robot
from service.states import configurations

MAX_SAMPLES_PER_INTERVAL = 64
MAX_EVALUATED_POINTS = 1_000_000  # states whose τ one check computes
CHUNK_NUMBERS = 262_144  # evaluated points × nv computed at once (2 MB an array)
MAX_CHUNK_POINTS = 20_000  # evaluated points between two `should_stop` checks at most

Friction = Callable[[np.ndarray], np.ndarray]  # v (n, nv) → friction torque (n, nv)


@dataclass
class TrajectoryCheck:
    """The outcome of `check_trajectory`. `tau` and `v` are at the samples (N, nv)."""

    feasible: bool
    tau: np.ndarray
    v: np.ndarray
    joints: list[dict[str, Any]]
    violations: list[dict[str, Any]]
    work: dict[str, float]

    def answer(self) -> dict[str, Any]:
        """The contract's answer — feasible, tau, joints, violations, work — and the velocities
        `v` at the samples (as given, or the spline's)."""
        return {
            "feasible": self.feasible,
            "tau": self.tau,
            "v": self.v,
            "joints": self.joints,
            "violations": self.violations,
            "work": self.work,
        }


def check_work(samples: int, samples_per_interval: int, spline: bool, nv: int) -> int:
    """The work of a check of N `samples`: its evaluated points × nv (`spline`: v and a both
    come from the spline, so k − 1 points inside every interval are evaluated too)."""
    return evaluated_points(samples, samples_per_interval, spline) * nv


def admit_check(
    samples: int, samples_per_interval: int, spline: bool, nv: int, max_work: int | None
) -> None:
    """InvalidInput when the check's work (`check_work`) is over `max_work` (None: no limit,
    as for a script), naming the limit, the factors and how many samples of this request fit
    (members `work`, `max_work`, `largest_samples`)."""
    work = check_work(samples, samples_per_interval, spline, nv)
    if max_work is None or work <= max_work:
        return
    k = samples_per_interval if spline else 1
    points = evaluated_points(samples, k, spline)
    fitting = max_work // nv  # evaluated points
    largest = (fitting - 1) // k + 1 if fitting >= 1 else 0
    factors = f"{points:,} evaluated points (the samples)"
    fits = f"{largest:,} samples"
    fewer = "send fewer samples"
    if k > 1:
        factors = f"{points:,} evaluated points ({samples:,} samples, {k} points per interval)"
        fits += f" at {k} points per interval"
        fewer += " or a smaller samples_per_interval"
    raise InvalidInput(
        f"trajectory-check: the work of this check, {factors} × nv = {nv} = {work:,} units, is "
        f"over the limit of {max_work:,} (ROBODYN_MAX_TRAJECTORY_WORK; a unit is one joint at "
        f"one evaluated point): at most {fits} of this robot fit in one check; {fewer}, or "
        "check the motion in parts",
        work=work,
        max_work=max_work,
        largest_samples=largest,
    )


def chunk_points(nv: int) -> int:
    """Evaluated points computed at once for a robot of `nv` velocities."""
    return max(64, min(MAX_CHUNK_POINTS, CHUNK_NUMBERS // max(nv, 1)))


def check_trajectory(
    robot: Robot,
    t: Any,
    q: Any,
    v: Any = None,
    a: Any = None,
    *,
    effort_scale: float = 1.0,
    velocity_scale: float = 1.0,
    acceleration: Any = None,
    boundary: str = "not-a-knot",
    samples_per_interval: int = 4,
    friction: Friction | None = None,
) -> TrajectoryCheck:
    """Check the motion (t, q[, v, a]) of `robot` against its effort, velocity and position
    limits (effort and velocity limits × `effort_scale`, `velocity_scale`) and the joint
    acceleration limits `acceleration` [nv] (None, or an entry None: no limit). `boundary`:
    the spline's end conditions where v or a is absent. q is in the API's order
    (`Robot.pinocchio_q`). `friction(v)`, where given, adds a friction torque to τ. Raises
    InvalidInput / DimensionMismatch naming the field at fault."""
    times = sample_times("t", t)
    n = times.shape[0]
    qs = configurations(robot, samples("q", q, n, robot.nq, "nq", "t"))
    vs = None if v is None else samples("v", v, n, robot.nv, "nv", "t")
    acc = None if a is None else samples("a", a, n, robot.nv, "nv", "t")
    return check_samples(
        robot,
        times,
        qs,
        vs,
        acc,
        effort_scale=effort_scale,
        velocity_scale=velocity_scale,
        acceleration=acceleration,
        boundary=boundary,
        samples_per_interval=samples_per_interval,
        friction=friction,
    )


def check_samples(
    robot: Robot,
    times: np.ndarray,
    qs: np.ndarray,
    vs: np.ndarray | None,
    acc: np.ndarray | None,
    *,
    effort_scale: float = 1.0,
    velocity_scale: float = 1.0,
    acceleration: Any = None,
    boundary: str = "not-a-knot",
    samples_per_interval: int = 4,
    friction: Friction | None = None,
    max_work: int | None = None,
    should_stop: ShouldStop | None = None,
) -> TrajectoryCheck:
    """`check_trajectory` of checked samples: times (N,) strictly increasing, qs (N, nq) in
    Pinocchio's order, vs and acc (N, nv) or None. Over `max_work` (evaluated points × nv;
    None: no limit) an InvalidInput before anything is computed (`admit_check`).
    `should_stop()` (optional) is asked between chunks of evaluated points
    (`service.dynamics.stopping`)."""
    n = times.shape[0]
    effort_scale = positive("effort_scale", effort_scale)
    velocity_scale = positive("velocity_scale", velocity_scale)
    accel = acceleration_limits("limits.acceleration", acceleration, robot.nv)
    if boundary not in BOUNDARIES:
        raise InvalidInput(f"boundary must be one of {', '.join(BOUNDARIES)}")
    k = _samples_per_interval(samples_per_interval)
    given = vs is not None or acc is not None
    if (vs is None or acc is None) and robot.nq != robot.nv:
        raise InvalidInput(
            f"v and a are required for robot '{robot.id}': its configuration has nq = "
            f"{robot.nq} numbers and its velocity nv = {robot.nv}, so v and a cannot be "
            "derivatives of a spline through q"
        )
    step = 1 if given else k  # evaluated points per interval
    points = evaluated_points(n, step, True)
    if points > MAX_EVALUATED_POINTS and step > 1:
        raise InvalidInput(
            f"samples_per_interval: {n} samples × {k} points per interval "
            f"exceed the {MAX_EVALUATED_POINTS} points one check evaluates"
        )
    admit_check(n, step, not given, robot.nv, max_work)
    spline = SampleSpline(times, qs, boundary) if vs is None or acc is None else None
    stop = Stopper(
        should_stop,
        "the trajectory check",
        "evaluated point",
        total=points,
        stage="inverse dynamics",
    )
    summary = MotionSummary(robot, effort_scale, velocity_scale, accel)
    loads = JointLoadPeaks(robot, float(np.diff(times).max()))
    tau = np.empty((n, robot.nv))
    v_samples = np.empty((n, robot.nv)) if vs is None else vs
    for chunk in chunks(times, qs, vs, acc, spline, step, chunk_points(robot.nv)):
        stop.poll(chunk.first)
        tau_chunk, wrenches = inverse_dynamics_with_loads(
            robot, chunk.q, chunk.v, chunk.a, friction
        )
        _require_finite_torques(tau_chunk, chunk.t, times, given)
        summary.add(chunk.t, chunk.q, chunk.v, chunk.a, tau_chunk)
        loads.add(chunk.t, chunk.v, tau_chunk, wrenches)
        tau[chunk.samples] = tau_chunk[chunk.sample_rows]
        if vs is None:
            v_samples[chunk.samples] = chunk.v[chunk.sample_rows]
    joints = [
        {**joint, **figures}
        for joint, figures in zip(summary.joints(), loads.figures(), strict=True)
    ]
    violations = summary.violations.in_time_order()
    return TrajectoryCheck(
        feasible=not violations,
        tau=tau,
        v=v_samples,
        joints=joints,
        violations=violations,
        work=summary.total_work(),
    )


def _require_finite_torques(tau: np.ndarray, t: np.ndarray, times: np.ndarray, given: bool) -> None:
    """NonFiniteResult naming the first time where τ is not finite, and the inputs there."""
    bad = np.flatnonzero(~np.isfinite(tau).all(axis=1))
    if not bad.size:
        return
    at = float(t[int(bad[0])])
    i = min(int(np.searchsorted(times, at, side="right")) - 1, times.size - 1)
    inputs = "v and a" if given else "the spline's velocities and accelerations"
    raise NonFiniteResult(
        f"trajectory-check: τ at t = {at:.6g} s (sample {i}) is not a finite number: q, "
        f"{inputs} there are too large to compute with"
    )


def _samples_per_interval(value: Any) -> int:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, np.integer))
        or not (1 <= value <= MAX_SAMPLES_PER_INTERVAL)
    ):
        raise InvalidInput(
            f"samples_per_interval must be an integer from 1 to {MAX_SAMPLES_PER_INTERVAL}"
        )
    return int(value)
