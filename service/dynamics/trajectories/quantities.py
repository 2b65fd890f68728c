"""The trajectory quantities as the service serves them (`POST /v1/robots/{id}/<name>`): their
functions over validated `States` and their declarations.

- trajectory-check: the samples' q (and optional v, a) are the states, `t` an option;
- retime: the waypoints are the states (`waypoints`, each nq numbers), the limits and the
  sample step options.
"""

from __future__ import annotations

import math
from typing import Any

from service.dynamics.equation_of_motion import joint_friction
from service.dynamics.quantity import Quantity
from service.dynamics.stopping import ShouldStop
from service.dynamics.trajectories import retiming
from service.dynamics.trajectories.check import check_samples
from service.dynamics.trajectories.evaluation import evaluated_points
from service.dynamics.trajectories.inputs import sample_times
from service.errors import DimensionMismatch, InvalidInput, PayloadTooLarge
from service.registry.robot import Robot
from service.states import States

JSON_BYTES_PER_NUMBER = 25  # as the answer budget counts a number in JSON


def trajectory_check(
    robot: Robot,
    s: States,
    *,
    t: Any,
    limits: dict[str, Any] | None = None,
    effort_scale: float | None = None,
    velocity_scale: float | None = None,
    boundary: str = "not-a-knot",
    samples_per_interval: int = 4,
    friction: bool = False,
    max_trajectory_work: int | None = None,
    should_stop: ShouldStop | None = None,
) -> dict[str, Any]:
    """Check the motion sampled at times `t` [N] (s, strictly increasing, N ≥ 2) with
    configurations q [N][nq] and optional velocities v and accelerations a [N][nv] against the
    robot's effort, velocity and position limits and the joint acceleration limits given:
    `limits` {velocity_scale, effort_scale, acceleration [nv] (an entry null: no limit)}
    (the scales may also come at top level, not both forms at once). Where v and a are absent
    they are the derivatives of the cubic spline through (t, q) with the `boundary` conditions
    not-a-knot (default), clamped (zero velocity at both ends: rest to rest) or natural (zero
    acceleration at both ends) (robots with nq = nv), and k − 1 evenly spaced points inside
    every interval are evaluated too (k = samples_per_interval, at most 64). τ = M(q) a +
    C(q, v) v + g(q) by RNEA at every evaluated point. Answer: `feasible`, `tau` [N][nv] and
    `v` [N][nv] at the samples, per 1-DoF joint its limits, peaks of |τ|, |v| and |a| and
    ratios (peak ÷ limit over every evaluated point, null without a limit) and its sizing
    figures (rms_effort √(∫ τ² dt ÷ duration), peak_power max |τ v| in W, and the peaks of
    the wrench (f, n) it transmits, in its frame with s its axis: peak_force ‖f‖, peak_moment
    ‖n‖, peak_axial_force |f · s|, peak_bending_moment ‖n − (n · s) s‖), the `violations`
    with their time spans, and the `work` (J): ∫ max(τᵀv, 0) dt and ∫ min(τᵀv, 0) dt. The
    samples are one motion: never split into batches of states; its evaluated points are
    computed in chunks, and `should_stop` is asked between them.
    With `friction` (a robot made by identification) τ includes the joints' friction torque,
    offset + coulomb ∘ sign(v) + viscous ∘ v (and the joint loads, along each joint's axis).
    Its work, evaluated points × nv, is at most `max_trajectory_work` (the service's setting;
    over it a 422 before computing)."""
    scales = _check_scales(limits, effort_scale, velocity_scale)
    times = sample_times("t", t)
    q = s["q"]
    if q.shape[0] != times.shape[0]:
        raise DimensionMismatch(f"q has {q.shape[0]} samples; t has {times.shape[0]}")
    result = check_samples(
        robot,
        times,
        q,
        s.arrays.get("v"),
        s.arrays.get("a"),
        effort_scale=scales.get("effort_scale", 1.0),
        velocity_scale=scales.get("velocity_scale", 1.0),
        acceleration=scales.get("acceleration"),
        boundary=boundary,
        samples_per_interval=samples_per_interval,
        friction=joint_friction(robot) if friction else None,
        max_work=max_trajectory_work,
        should_stop=should_stop,
    )
    return {
        "feasible": result.feasible,
        "tau": result.tau,
        "v": result.v,
        "joints": result.joints,
        "violations": result.violations,
        "work": result.work,
    }


def _check_scales(
    limits: dict[str, Any] | None, effort_scale: float | None, velocity_scale: float | None
) -> dict[str, Any]:
    """The check's limits from either form: the `limits` object, or the scales at top
    level; both at once is an InvalidInput."""
    top = {
        name: value
        for name, value in (("effort_scale", effort_scale), ("velocity_scale", velocity_scale))
        if value is not None
    }
    if limits is not None and top:
        raise InvalidInput(
            f"{' and '.join(top)} at top level and limits: give the scales in one place, "
            "preferably limits (velocity_scale, effort_scale, acceleration)"
        )
    return dict(limits) if limits is not None else top


def check_work(robot: Robot, s: States, options: dict[str, Any]) -> int:
    """Evaluated points × nv (with k points per interval where v and a come from the spline)."""
    k = options.get("samples_per_interval", 4)
    spline = "v" not in s.arrays and "a" not in s.arrays
    points = k if spline and isinstance(k, int) and k > 0 else 1
    return evaluated_points(s.count, points, spline) * robot.nv


def check_size(robot: Robot, options: dict[str, Any], with_v: bool) -> int:
    """τ and v at each sample (the joints' entries, violations and work come on top, once)."""
    return 2 * robot.nv


def retime(
    robot: Robot,
    s: States,
    *,
    limits: dict[str, Any] | None = None,
    sample_dt: float = 0.01,
    max_answer_bytes: int | None = None,
    max_retime_work: int | None = None,
    should_stop: ShouldStop | None = None,
) -> dict[str, Any]:
    """The time-optimal motion along the cubic spline through `waypoints` [K][nq] (K ≥ 2;
    clamped: zero derivative at both ends; parameterised by the cumulative joint-space
    distance between waypoints), from rest to rest, under the joint velocity limits ×
    limits.velocity_scale, the effort limits × limits.effort_scale and the joint accelerations
    limits.acceleration [nv] where given (an entry null: no limit on that joint): TOPP-RA
    (toppra) with the limits kept at 3 points of each of 800 + 16 per segment path intervals,
    then verified between them and corrected, so that the motion is within every limit
    everywhere (1e-6 relative) and at most 1 % slower than the optimum. A waypoint on a
    position limit is within it. Answer: `duration` (s), samples
    every `sample_dt` s and at the end — `t` [M], `q` [M][nq], `v`, `a`, `tau` [M][nv] — and
    `check`, the trajectory check of those samples. Robots whose joints are all revolute or
    prismatic (else 422 unsupported_model); a path no timing can follow is 422
    infeasible_path, naming the joint and where along the path. Its work, path intervals × nv ×
    limited quantities, is at most `max_retime_work` (the service's setting; over it a 422
    before computing)."""
    options = dict(limits or {})
    numbers = 1 + robot.nq + 5 * robot.nv  # a sample's t, q, v, a, τ and the check's τ, v
    max_samples = retiming.MAX_SAMPLES
    if max_answer_bytes is not None:
        max_samples = min(max_samples, max_answer_bytes // (numbers * JSON_BYTES_PER_NUMBER))
    try:
        result = retiming.retime(
            robot,
            s["waypoints"],
            sample_dt=sample_dt,
            velocity_scale=options.get("velocity_scale", 1.0),
            effort_scale=options.get("effort_scale", 1.0),
            acceleration=options.get("acceleration"),
            max_samples=max_samples,
            max_work=max_retime_work,
            should_stop=should_stop,
        )
    except retiming.TooManySamples as exc:
        if max_samples == retiming.MAX_SAMPLES:
            raise InvalidInput(str(exc)) from None
        raise PayloadTooLarge(f"{exc} (the answer would exceed ROBODYN_MAX_ANSWER_BYTES)") from None
    # The check is a nested object: its arrays as lists (the binary form carries only the
    # top-level arrays as tensors, and everything else as JSON).
    check = {k: v.tolist() if hasattr(v, "tolist") else v for k, v in result.check.answer().items()}
    return {
        "duration": result.duration,
        "t": result.t,
        "q": robot.api_q(result.q),
        "v": result.v,
        "a": result.a,
        "tau": result.tau,
        "check": check,
    }


def retime_work(robot: Robot, s: States, options: dict[str, Any]) -> int:
    """Always over the inline limit: a retiming takes tens of milliseconds."""
    return 1_000_000 + s.count * robot.nv


def retime_size(robot: Robot, options: dict[str, Any], with_v: bool) -> int:
    """Nominal, per waypoint: the samples' count follows from the duration, known only after
    solving; `retime` itself refuses a motion whose samples would exceed the answer budget."""
    return math.ceil((1 + robot.nq + 5 * robot.nv) / 2)


TRAJECTORIES = (
    Quantity(
        "trajectory-check",
        ("q",),
        trajectory_check,
        "Check a sampled motion against the robot's effort, velocity and position limits",
        optional=("v", "a"),
        joint_answers=("tau", "v"),
        work=check_work,
        settings=("max_trajectory_work",),
        tensor_options=("t",),
        answer_size=check_size,
    ),
    Quantity(
        "retime",
        ("waypoints",),
        retime,
        "Time a path through waypoints optimally under velocity, acceleration and torque "
        "limits, every limit kept between samples too",
        joint_answers=("q", "v", "a", "tau"),
        settings=("max_answer_bytes", "max_retime_work"),
        work=retime_work,
        answer_size=retime_size,
    ),
)
