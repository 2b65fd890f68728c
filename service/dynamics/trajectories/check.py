"""Does a sampled joint trajectory stay within the robot's limits?

Input: samples at times t [N] (s, strictly increasing, N ≥ 2) of q [N, nq], and optionally v and
a [N, nv]. Where v and a are absent they are the derivatives of the not-a-knot cubic spline
through (t, q) (`scipy.interpolate.CubicSpline`, one spline per coordinate; robots with
nq = nv only), and the check also evaluates k − 1 evenly spaced points inside every interval
(k = `samples_per_interval`), so that a limit broken between two samples is found. Where v and
a are given, the motion is known at the samples only and is evaluated there.

At every evaluated point: τ = M(q) a + C(q, v) v + g(q) (+ friction(v) where a friction model
is given), by batch RNEA. Answer: τ at the samples, per 1-DoF joint the peaks of |τ| and |v|,
the extremes of q and their ratios to the limits (`limits.joint_limits`), the violations with
their time spans (`limits.spans_over`), and the work: the integrals over time of max(τᵀv, 0)
(positive, J) and min(τᵀv, 0) (negative, J) by the trapezoidal rule over the evaluated points.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from service.dynamics.stopping import ShouldStop, Stopper
from service.dynamics.trajectories import rnea
from service.dynamics.trajectories.inputs import positive, sample_times, samples
from service.dynamics.trajectories.limits import joint_limits, spans_over
from service.errors import InvalidInput, NonFiniteResult
from service.registry.robot import Robot
from service.states import configurations

MAX_SAMPLES_PER_INTERVAL = 64
MAX_EVALUATED_POINTS = 1_000_000  # states whose τ one check computes
RNEA_BATCH = 20_000  # evaluated points per batch of RNEA (between two `should_stop` checks)

Friction = Callable[[np.ndarray], np.ndarray]  # v (n, nv) → friction torque (n, nv)


@dataclass
class TrajectoryCheck:
    """The outcome of `check_trajectory`. `tau`, `v`, `a` are at the samples (N, nv); `t_eval`,
    `tau_eval`, `v_eval`, `q_eval` at every evaluated point (samples and points inside the
    intervals, in time order)."""

    feasible: bool
    tau: np.ndarray
    v: np.ndarray
    a: np.ndarray
    joints: list[dict[str, Any]]
    violations: list[dict[str, Any]]
    work: dict[str, float]
    t_eval: np.ndarray = field(repr=False)
    q_eval: np.ndarray = field(repr=False)
    v_eval: np.ndarray = field(repr=False)
    tau_eval: np.ndarray = field(repr=False)

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


def evaluation_times(t: np.ndarray, k: int) -> np.ndarray:
    """The samples t [N] and k − 1 evenly spaced times inside each interval: (N − 1) k + 1
    times in increasing order; sample i is at index i·k."""
    steps = np.arange(k) / k
    inner = (t[:-1, None] + np.diff(t)[:, None] * steps[None, :]).reshape(-1)
    return np.concatenate([inner, t[-1:]])


def check_trajectory(
    robot: Robot,
    t: Any,
    q: Any,
    v: Any = None,
    a: Any = None,
    *,
    effort_scale: float = 1.0,
    velocity_scale: float = 1.0,
    samples_per_interval: int = 4,
    friction: Friction | None = None,
) -> TrajectoryCheck:
    """Check the motion (t, q[, v, a]) of `robot` against its effort, velocity and position
    limits (effort and velocity limits × `effort_scale`, `velocity_scale`). q is in the API's
    order (`Robot.pinocchio_q`). `friction(v)`, where given, adds a friction torque to τ.
    Raises InvalidInput / DimensionMismatch naming the field at fault."""
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
    samples_per_interval: int = 4,
    friction: Friction | None = None,
    should_stop: ShouldStop | None = None,
) -> TrajectoryCheck:
    """`check_trajectory` of checked samples: times (N,) strictly increasing, qs (N, nq) in
    Pinocchio's order, vs and acc (N, nv) or None. `should_stop()` (optional) is asked
    between batches of RNEA_BATCH evaluated points (`service.dynamics.stopping`)."""
    n = times.shape[0]
    effort_scale = positive("effort_scale", effort_scale)
    velocity_scale = positive("velocity_scale", velocity_scale)
    k = _samples_per_interval(samples_per_interval)
    given_v, given_a = vs, acc
    if vs is None or acc is None:
        if robot.nq != robot.nv:
            raise InvalidInput(
                f"v and a are required for robot '{robot.id}': its configuration has nq = "
                f"{robot.nq} numbers and its velocity nv = {robot.nv}, so v and a cannot be "
                "derivatives of a spline through q"
            )
        spline = SampleSpline(times, qs)
        if vs is None:
            vs = spline.values(1, 1)
        if acc is None:
            acc = spline.values(2, 1)
    if given_v is None and given_a is None and k > 1:
        if (n - 1) * k + 1 > MAX_EVALUATED_POINTS:
            raise InvalidInput(
                f"samples_per_interval: {n} samples × {k} points per interval "
                f"exceed the {MAX_EVALUATED_POINTS} points one check evaluates"
            )
        t_eval = evaluation_times(times, k)
        q_eval, v_eval, a_eval = (spline.values(order, k) for order in (0, 1, 2))
        q_eval[::k], v_eval[::k], a_eval[::k] = qs, vs, acc  # the samples exactly as given
        at_samples = slice(None, None, k)
    else:
        t_eval, q_eval, v_eval, a_eval = times, qs, vs, acc
        at_samples = slice(None)
    stop = Stopper(
        should_stop,
        "the trajectory check",
        "evaluated point",
        total=q_eval.shape[0],
        stage="inverse dynamics",
    )
    tau_eval = np.empty((q_eval.shape[0], robot.nv))
    for start in range(0, q_eval.shape[0], RNEA_BATCH):
        stop.poll(start)
        end = start + RNEA_BATCH
        tau_eval[start:end] = rnea.inverse_dynamics(
            robot, q_eval[start:end], v_eval[start:end], a_eval[start:end], checked=False
        )
    if friction is not None:
        with np.errstate(over="ignore", invalid="ignore"):
            tau_eval = tau_eval + friction(v_eval)
    _require_finite_torques(tau_eval, t_eval, times, given_v is not None or given_a is not None)
    joints, violations = _against_limits(
        robot, t_eval, q_eval, v_eval, tau_eval, effort_scale, velocity_scale
    )
    with np.errstate(over="ignore", invalid="ignore"):
        power = np.einsum("ij,ij->i", tau_eval, v_eval)
        work = {
            "positive": float(np.trapezoid(np.maximum(power, 0.0), t_eval)),
            "negative": float(np.trapezoid(np.minimum(power, 0.0), t_eval)),
        }
    if not all(np.isfinite(w) for w in work.values()):
        raise NonFiniteResult(
            "trajectory-check: the work ∫ τᵀv dt of this motion overflows float64 (its "
            "torques, velocities or duration are too large to compute with)"
        )
    tau = np.ascontiguousarray(tau_eval[at_samples])  # (orjson writes C-contiguous arrays)
    return TrajectoryCheck(
        feasible=not violations,
        tau=tau,
        v=vs,
        a=acc,
        joints=joints,
        violations=violations,
        work=work,
        t_eval=t_eval,
        q_eval=q_eval,
        v_eval=v_eval,
        tau_eval=tau_eval,
    )


class SampleSpline:
    """The not-a-knot cubic spline through (t, q), kept in the unit time τ = (t − t₀) / T
    (T the largest sample interval, τ built from the intervals), so that its pieces never
    raise t to the third power: q(t) = Q(τ), q̇ = Q'(τ) / T, q̈ = Q''(τ) / T². InvalidInput
    names the samples where q changes faster than float64 holds (Δq / Δt, or a derivative
    of the spline, overflows)."""

    def __init__(self, times: np.ndarray, qs: np.ndarray) -> None:
        steps = np.diff(times)
        with np.errstate(over="ignore", invalid="ignore"):
            slopes = np.diff(qs, axis=0) / steps[:, None]
        bad = np.flatnonzero(~np.isfinite(slopes).all(axis=1))
        self.times = times
        if bad.size:
            raise self._too_fast(int(bad[0]), "velocity overflows")
        self.unit = float(steps.max())  # T, s
        self.tau = np.concatenate([[0.0], np.cumsum(steps / self.unit)])
        self.spline = CubicSpline(self.tau, qs, bc_type="not-a-knot", axis=0)

    def values(self, order: int, k: int) -> np.ndarray:
        """The `order`-th time derivative at the samples and k − 1 evenly spaced times inside
        every interval (`evaluation_times`; k = 1: the samples)."""
        with np.errstate(over="ignore", invalid="ignore", under="ignore"):
            values = np.asarray(self.spline(evaluation_times(self.tau, k), order))
            for _ in range(order):  # one division at a time: T² alone may under- or overflow
                values = values / self.unit
        bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
        if bad.size:
            what = ("position", "velocity", "acceleration")[order]
            i = min(int(bad[0]) // k, self.times.size - 2)
            raise self._too_fast(i, f"spline's {what} overflows")
        return values

    def _too_fast(self, i: int, what: str) -> InvalidInput:
        return InvalidInput(
            f"t and q: between samples {i} and {i + 1} (t = {self.times[i]:.6g} s and "
            f"{self.times[i + 1]:.6g} s) q changes too fast to compute with for these times: "
            f"its {what} float64"
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


def _ratio(peak: float, limit: float | None, joint: str, scale: str) -> float | None:
    """peak ÷ limit, or InvalidInput naming the scale that made the limit too small for it."""
    if limit is None:
        return None
    with np.errstate(over="ignore"):
        ratio = float(np.float64(peak) / limit)
    if not np.isfinite(ratio):
        raise InvalidInput(
            f"{scale} is too small to compute with: joint '{joint}''s limit becomes "
            f"{limit:.3g}, and its peak over it overflows float64"
        )
    return ratio


def _against_limits(
    robot: Robot,
    t: np.ndarray,
    q: np.ndarray,
    v: np.ndarray,
    tau: np.ndarray,
    effort_scale: float,
    velocity_scale: float,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Per 1-DoF joint: peaks, extremes, ratios (peak ÷ limit) and violations, sorted by
    start time."""
    joints, violations = [], []
    for lim in joint_limits(robot, effort_scale, velocity_scale):
        effort, speed = tau[:, lim.iv], v[:, lim.iv]
        peak_effort, peak_velocity = float(np.abs(effort).max()), float(np.abs(speed).max())
        position = q[:, lim.iq] if lim.positioned else None
        joints.append(
            {
                "name": lim.name,
                "effort_limit": lim.effort,
                "peak_effort": peak_effort,
                "effort_ratio": _ratio(peak_effort, lim.effort, lim.name, "effort_scale"),
                "velocity_limit": lim.velocity,
                "peak_velocity": peak_velocity,
                "velocity_ratio": _ratio(peak_velocity, lim.velocity, lim.name, "velocity_scale"),
                "lower": lim.lower,
                "upper": lim.upper,
                "min_position": None if position is None else float(position.min()),
                "max_position": None if position is None else float(position.max()),
            }
        )
        if lim.effort is not None:
            violations += spans_over(lim.name, "effort", t, effort, -lim.effort, lim.effort)
        if lim.velocity is not None:
            violations += spans_over(lim.name, "velocity", t, speed, -lim.velocity, lim.velocity)
        if position is not None:
            violations += spans_over(lim.name, "position", t, position, lim.lower, lim.upper)
    violations.sort(key=lambda x: (x["t_start"], x["joint"], x["kind"]))
    return joints, violations
