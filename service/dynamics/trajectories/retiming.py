"""The time-optimal timing of a path through waypoints, under joint velocity, acceleration and
torque limits, that provably stays within them — TOPP-RA (the `toppra` package), then checked
and corrected.

1. The path: the clamped cubic spline through the waypoints, near-duplicates merged
   (`path.WaypointPath`).
2. The grid (`gridpoints`): each spline segment gets MIN_SEGMENT_INTERVALS intervals plus its
   share by length of INTERVALS, denser towards its knots (the spline's knots among the
   gridpoints), and a verification grid of V + 1 points per interval (`VERIFY_POINTS`).
3. Before any timing: a path that leaves a joint's position limits (the spline's exact
   extremes), or on which gravity alone needs more than a joint's torque limit, is
   `InfeasiblePath`: no timing can follow it.
4. TOPP-RA (toppra's `TOPPRA` with its seidel solver) with the limits enforced at m + 1 points
   of every interval (`constraints`, m = `SOLVE_POINTS`: its ends and middle), each limit
   tightened by `INITIAL_MARGIN`: the path speed profile x = ṡ² at the gridpoints
   (`profile.Profile`). The solver works in the path's own units (`toppra_rows`: s / L and
   x / x̄), so that a path 1e-10 rad long, or limits 1e-10 of the model's, are timed like any
   other; a limit whose path quantities overflow float64 is an InvalidInput naming it
   (`families`).
5. The exact timed motion on the verification grid: every limited quantity's estimated maximum
   over each interval (`envelope`: the points' maximum plus a curvature margin) divided by
   its limit. Where one exceeds `TIGHTEN_ABOVE`, the limits of that interval are tightened by
   the square of the overshoot and TOPP-RA runs again (up to `MAX_TIGHTENINGS` times; the
   motion slows there only); what overshoot remains (about 1e-4) is removed by slowing the
   whole motion uniformly by the smallest factor that does it (`families.slowdown`), which
   lengthens it by about half the overshoot.
6. The answer: the motion sampled every `sample_dt` (and at its end), τ by RNEA, and the
   trajectory check of those samples. A motion longer than `max_samples` × `sample_dt` is
   refused (`TooManySamples`) however long it is: the limits decide what is infeasible, never
   the motion's length.

Cost: TOPP-RA's rows (the limited quantities of every joint at 3 points of every interval), the
path on the verification grid (9 points of every interval) and their solve grow with the
path's intervals × nv × the limited quantities (`retime_work`), and
are held at once (the solver needs the whole path). A request over `max_work` is refused before
anything is computed (`admit_retime`: the service's ROBODYN_MAX_RETIME_WORK), from its number
of waypoints: the grid has at most INTERVALS + MIN_SEGMENT_INTERVALS × (K − 1) intervals.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from service.dynamics.stopping import ShouldStop, Stopper
from service.dynamics.trajectories import rnea
from service.dynamics.trajectories.check import TrajectoryCheck, check_trajectory
from service.dynamics.trajectories.constraints import Family
from service.dynamics.trajectories.envelope import lower_envelope, upper_envelope
from service.dynamics.trajectories.families import (
    PathSamples,
    families,
    interval_ratios,
    ratios,
    sample_path,
    slowdown,
    subsample,
)
from service.dynamics.trajectories.inputs import acceleration_limits, positive
from service.dynamics.trajectories.limits import JointLimit, joint_limits, slack
from service.dynamics.trajectories.path import WaypointPath
from service.dynamics.trajectories.profile import Profile
from service.errors import InfeasiblePath, InvalidInput, UnsupportedModel
from service.registry.robot import Robot

# toppra's warnings (a re-run, a slowdown) are decisions taken here, not news for the log
logging.getLogger("toppra").setLevel(logging.ERROR)

INTERVALS = 800  # TOPP-RA intervals along the path, shared among its segments by length
MIN_SEGMENT_INTERVALS = 16  # more per spline segment (a path that turns often: a finer grid)
SOLVE_POINTS = 2  # m: points per interval (besides its start) where the solver keeps limits
VERIFY_POINTS = 8  # V: points per interval (a multiple of m) where the timing is verified
INITIAL_MARGIN = 1e-6  # the solver sees every limit × (1 − this)
TIGHTEN_ABOVE = 1.002  # an interval whose ratio is above this gets its limits tightened
MAX_TIGHTENINGS = 3
TIGHTEN_POWER = 2.0  # by its ratio to this power (beyond the overshoot: one run, mostly)
ROW_GROUP = 8  # solver rows per toppra constraint object
MAX_SAMPLES = 20_000  # samples of the answer (200 s every 0.01 s)
MAX_PATH_SPEED2 = 1e7  # X = ṡ² / x̄ this large: no limit bounds the speed (toppra caps at 1e8)


@dataclass
class Retimed:
    """The timed motion: `duration` (s), samples `t` [M], `q` [M, nq], `v`, `a`, `tau`
    [M, nv], its `check`, and how it was obtained: `toppra_duration` (TOPP-RA's first
    answer), `resolves` (TOPP-RA runs after the first), `slowdown` (the uniform time-scaling
    factor, 1 if none), `worst_ratio` (the largest estimated value of a limited quantity over
    its limit on the verification grid, ≤ 1), `profile` (the exact timing)."""

    duration: float
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    tau: np.ndarray
    check: TrajectoryCheck
    toppra_duration: float
    resolves: int
    slowdown: float
    worst_ratio: float
    profile: Profile = field(repr=False)

    def answer(self) -> dict[str, Any]:
        return {
            "duration": self.duration,
            "t": self.t,
            "q": self.q,
            "v": self.v,
            "a": self.a,
            "tau": self.tau,
            "check": self.check.answer(),
        }


def gridpoints(path: WaypointPath, intervals: int = INTERVALS) -> np.ndarray:
    """The grid of a path: each spline segment [s_k, s_{k+1}] gets MIN_SEGMENT_INTERVALS
    intervals plus its share of `intervals` by length (rounded down), so every knot is a
    gridpoint and the path is one cubic polynomial on every interval. Within a segment the
    gridpoints are denser towards its knots, s_k + (s_{k+1} − s_k) (1 − cos(π j / n)) / 2 for
    j = 0 … n − 1: where the path turns, and where the motion starts and stops, the path
    acceleration the limits allow changes fastest, and one constant path acceleration per
    interval loses most there."""
    pieces = []
    for s0, s1 in zip(path.knots[:-1], path.knots[1:], strict=True):
        count = MIN_SEGMENT_INTERVALS + int(intervals * (s1 - s0) / path.length)
        pieces.append(s0 + (s1 - s0) * (1.0 - np.cos(np.pi * np.arange(count) / count)) / 2.0)
    return np.concatenate([*pieces, path.knots[-1:]])


def path_intervals(waypoints: int, intervals: int = INTERVALS) -> int:
    """The most intervals of the grid (`gridpoints`) of a path through K `waypoints`: each of
    its K − 1 segments gets MIN_SEGMENT_INTERVALS plus its share of `intervals` by length,
    rounded down, so at most `intervals` + MIN_SEGMENT_INTERVALS × (K − 1) in all."""
    return intervals + MIN_SEGMENT_INTERVALS * max(waypoints - 1, 1)


def limited_quantities(acceleration: bool) -> tuple[str, ...]:
    """The quantities a retiming limits along the path: velocity and effort, and acceleration
    where acceleration limits are given."""
    return ("velocity", "effort", "acceleration") if acceleration else ("velocity", "effort")


def retime_work(waypoints: int, nv: int, acceleration: bool, intervals: int = INTERVALS) -> int:
    """The work of a retiming: path intervals (at most, `path_intervals`) × nv × limited
    quantities."""
    return path_intervals(waypoints, intervals) * nv * len(limited_quantities(acceleration))


def admit_retime(
    waypoints: int, nv: int, acceleration: bool, max_work: int | None, intervals: int = INTERVALS
) -> None:
    """InvalidInput when the retiming's work (`retime_work`) is over `max_work` (None: no
    limit, as for a script), naming the limit, the factors and how many waypoints of this
    request fit (members `work`, `max_work`, `largest_waypoints`)."""
    work = retime_work(waypoints, nv, acceleration, intervals)
    if max_work is None or work <= max_work:
        return
    quantities = limited_quantities(acceleration)
    fitting = max_work // (nv * len(quantities))  # intervals
    largest = max((fitting - intervals) // MIN_SEGMENT_INTERVALS + 1, 0)
    fits = f"at most {largest:,} waypoints" if largest >= 2 else "not even two waypoints"
    raise InvalidInput(
        f"retime: the work of this path, {path_intervals(waypoints, intervals):,} intervals "
        f"({intervals} + {MIN_SEGMENT_INTERVALS} per segment between {waypoints:,} waypoints) "
        f"× nv = {nv} × {len(quantities)} limited quantities ({', '.join(quantities)}) = "
        f"{work:,} units, is over the limit of {max_work:,} (ROBODYN_MAX_RETIME_WORK): {fits} "
        "of this robot fit in one retiming with these limits; send fewer waypoints, or time "
        "the path in parts",
        work=work,
        max_work=max_work,
        largest_waypoints=largest,
    )


class TooManySamples(InvalidInput):
    """The motion, sampled every sample_dt, would have more samples than allowed."""


def retime(
    robot: Robot,
    waypoints: Any,
    *,
    velocity_scale: float = 1.0,
    effort_scale: float = 1.0,
    acceleration: Any = None,
    sample_dt: float = 0.01,
    intervals: int = INTERVALS,
    max_samples: int = MAX_SAMPLES,
    max_work: int | None = None,
    should_stop: ShouldStop | None = None,
) -> Retimed:
    """Time the path through `waypoints` [K, nq] (K ≥ 2) as fast as the limits allow: the
    model's velocity limits × `velocity_scale`, effort limits × `effort_scale`, and the joint
    accelerations `acceleration` [nv] where given; from rest to rest. Raises UnsupportedModel
    (a joint other than revolute or prismatic), InfeasiblePath, InvalidInput (among them a
    work over `max_work`, before anything is computed: `admit_retime`; None: no limit).
    `should_stop()` (optional, `service.dynamics.stopping`) is asked between its steps."""
    odd = sorted(
        {kind for kind in robot.joint_types.values() if kind not in ("revolute", "prismatic")}
    )
    if odd:
        raise UnsupportedModel(
            f"retime needs joints that are all revolute or prismatic; robot "
            f"'{robot.id}' has {', '.join(odd)} joints"
        )
    velocity_scale = positive("limits.velocity_scale", velocity_scale)
    effort_scale = positive("limits.effort_scale", effort_scale)
    accel = acceleration_limits("limits.acceleration", acceleration, robot.nv)
    sample_dt = positive("sample_dt", sample_dt)
    path = WaypointPath(waypoints, robot.nq)
    admit_retime(path.waypoints.shape[0], robot.nv, accel is not None, max_work, intervals)
    limits = joint_limits(robot, effort_scale, velocity_scale, accel)
    grid = gridpoints(path, intervals)
    stop = Stopper(should_stop, "retime", "step", total=3, stage="path")
    stop.poll(0)
    dense = sample_path(robot, path, grid, VERIFY_POINTS)
    stop.stage = "TOPP-RA and correction"
    stop.poll(1)
    _require_followable(robot, path, dense, limits)
    fams, profile, toppra_duration, resolves = _solve_and_tighten(robot, path, grid, dense, limits)
    factor = 1.0
    worst = max(float(ratios(f, profile, dense.theta).max()) for f in fams)
    if worst > 1.0:
        profile, factor, worst = _slow_down(path, profile, dense, fams, limits)
    stop.stage = "samples and their check"
    stop.poll(2)
    t, q, v, a, tau = _samples(robot, path, profile, sample_dt, max_samples)
    check = check_trajectory(
        robot,
        t,
        q,
        v,
        a,
        effort_scale=effort_scale,
        velocity_scale=velocity_scale,
        acceleration=acceleration,
    )
    return Retimed(
        profile.duration,
        t,
        q,
        v,
        a,
        tau,
        check,
        toppra_duration,
        resolves,
        factor,
        worst,
        profile,
    )


def _where(path: WaypointPath, s: float) -> str:
    k, fraction = path.where(s)
    return f"at path fraction {fraction:.4g} (between waypoints {k} and {k + 1})"


def _require_followable(
    robot: Robot, path: WaypointPath, dense: PathSamples, limits: list[JointLimit]
) -> None:
    """InfeasiblePath at the first place along the path where it leaves a joint's position
    limits (the spline's exact extremes on each segment, beyond a bound by more than the
    checks' tolerance, `limits.slack`: a waypoint on a limit is within it), or gravity alone
    needs more than a joint's torque limit (estimated over each interval by its envelope, so
    a crossing between points is found too)."""
    found: list[tuple[float, JointLimit, str, float]] = []  # (s, joint, kind, value)
    low, s_low, high, s_high = path.extremes()
    for lim in limits:
        for bound, sign, extreme, place in (
            (lim.upper, 1.0, high[:, lim.iq], s_high[:, lim.iq]),
            (lim.lower, -1.0, low[:, lim.iq], s_low[:, lim.iq]),
        ):
            if bound is None:
                continue
            beyond = np.flatnonzero(sign * (extreme - bound) > slack(bound))
            if beyond.size:
                k = int(beyond[0])
                found.append((float(place[k]), lim, "position", float(extreme[k])))
        if lim.effort is None:
            continue
        f = dense.C[..., lim.iv]
        for bound, sign, envelope in (
            (lim.effort, 1.0, upper_envelope(f)),
            (-lim.effort, -1.0, lower_envelope(f)),
        ):
            beyond = np.flatnonzero(sign * (envelope - bound) >= 0)
            if beyond.size:
                i = int(beyond[0])
                over = np.flatnonzero(sign * (f[i] - bound) >= 0)
                j = int(over[0]) if over.size else int(np.argmax(sign * f[i]))
                found.append((float(dense.s[i, j]), lim, "effort", float(f[i, j])))
    if not found:
        return
    at, lim, kind, value = min(found, key=lambda item: item[0])
    k, fraction = path.where(at)
    unit = "N" if robot.joint_types.get(lim.name) == "prismatic" else "N·m"
    low_text = "-inf" if lim.lower is None else f"{lim.lower:.6g}"
    high_text = "inf" if lim.upper is None else f"{lim.upper:.6g}"
    what = (
        f"leaves its position limits [{low_text}, {high_text}]"
        if kind == "position"
        else f"needs {abs(value):.4g} {unit} against gravity alone, more than its torque limit "
        f"{lim.effort:.4g} {unit}"
    )
    raise InfeasiblePath(
        f"no timing can follow this path: joint '{lim.name}' {what} {_where(path, at)}",
        joint=lim.name,
        waypoint=k,
        path_fraction=fraction,
        kind=kind,
    )


def _toppra(
    path: WaypointPath,
    grid: np.ndarray,
    fams: list[Family],
    tightening: list[np.ndarray] | None,
) -> tuple[np.ndarray | None, np.ndarray]:
    """Run TOPP-RA with every family's rows at the solver's points, in the path's own units
    (`toppra_rows`: σ = s / L, X = x / x̄); (x = ṡ² at the gridpoints, or None when it finds
    no timing; the controllable sets K, in units of x̄)."""
    import toppra  # here, not at import: it imports matplotlib (see toppra_rows)
    import toppra.algorithm

    from service.dynamics.trajectories.toppra_rows import SampledRows, path_speed_scale

    every = VERIFY_POINTS // SOLVE_POINTS
    theta = np.linspace(0.0, 1.0, SOLVE_POINTS + 1)
    deltas = np.diff(grid)
    shrinks = tightening or [np.ones(len(f.joints)) for f in fams]
    rows = [
        subsample(f, every).rows(theta, deltas, (1.0 - INITIAL_MARGIN) * shrink)
        for f, shrink in zip(fams, shrinks, strict=True)
    ]
    a, b, c = (np.concatenate([r[i] for r in rows], axis=1) for i in range(3))
    speed2 = path_speed_scale(b, c)  # x̄
    with np.errstate(over="ignore", invalid="ignore"):
        a, b = a * (speed2 / path.length), b * speed2
    sigma = grid / path.length
    toppra_path = toppra.SplineInterpolator(
        path.knots / path.length, path(path.knots), bc_type="clamped"
    )
    # Rows in groups of at most ROW_GROUP: toppra's seidel solver multiplies each constraint's
    # rows by its F (here the identity, R × R) when it is set up, holding the GIL: stages × R
    # multiply-adds a row. At R ≥ ~50 numpy's BLAS runs that product on every thread (30–90 ms
    # instead of well under 1 ms on a busy machine); with R = 24, 1,800 stages of a 126-joint
    # path (3,400 rows) took 0.4–0.9 s, with R = 8 about 0.1 s. The rows, in the same order,
    # and the timing are the same whatever the grouping.
    parts = [
        SampledRows(a[:, i : i + ROW_GROUP], b[:, i : i + ROW_GROUP], c[:, i : i + ROW_GROUP])
        for i in range(0, a.shape[1], ROW_GROUP)
    ]
    instance = toppra.algorithm.TOPPRA(
        parts, toppra_path, gridpoints=sigma, solver_wrapper="seidel"
    )
    _, sd, _, K = instance.compute_parameterization(0.0, 0.0, return_data=True)
    if sd is None or not np.isfinite(sd).all():
        return None, K
    if np.max(np.asarray(sd) ** 2) > MAX_PATH_SPEED2:
        raise InvalidInput(
            "the limits do not bound the speed along this path (a joint that "
            "moves has no velocity limit): give limits.acceleration"
        )
    return np.asarray(sd) ** 2 * speed2, K


def _solve_and_tighten(
    robot: Robot,
    path: WaypointPath,
    grid: np.ndarray,
    dense: PathSamples,
    limits: list[JointLimit],
) -> tuple[list[Family], Profile, float, int]:
    """TOPP-RA with the limits at the solver's points of every interval, then (step 5) the
    limits of each interval where the timed motion goes beyond one between those points by
    more than TIGHTEN_ABOVE tightened there, by the overshoot to the power TIGHTEN_POWER, and
    TOPP-RA run again (up to MAX_TIGHTENINGS times). Returns (the limited quantities, the
    last timing, TOPP-RA's first duration, the number of TOPP-RA runs after the first)."""
    fams = families(dense, limits)
    if not fams:
        raise InvalidInput(
            f"robot '{robot.id}' has no velocity or effort limits; give limits.acceleration"
        )
    x, K = _toppra(path, grid, fams, None)
    if x is None:
        raise _no_timing(path, dense, K, limits)
    profile = Profile(grid, x)
    first, runs = profile.duration, 0
    intervals = len(grid) - 1
    tightening = [np.ones((intervals + 1, len(f.joints))) for f in fams]
    for _ in range(MAX_TIGHTENINGS):
        over = [interval_ratios(f, profile, dense.theta) for f in fams]  # (N, J) each
        if max(float(r.max()) for r in over) <= TIGHTEN_ABOVE:
            break
        for shrink, ratio in zip(tightening, over, strict=True):
            shrink[:intervals] /= np.maximum(ratio, 1.0) ** TIGHTEN_POWER
        x, _ = _toppra(path, grid, fams, tightening)
        if x is None:  # (rounding at a standstill): keep the last timing, slow it down
            break
        profile, runs = Profile(grid, x), runs + 1
    return fams, profile, first, runs


def _slow_down(
    path: WaypointPath,
    profile: Profile,
    dense: PathSamples,
    fams: list[Family],
    limits: list[JointLimit],
) -> tuple[Profile, float, float]:
    """Slow the whole motion by the smallest factor that brings every family within its
    limits (step 5's last resort); (profile, factor, worst ratio)."""
    factor = 1.0
    for _ in range(50):
        needs = [slowdown(f, profile, dense.theta, 1.0 - 1e-9) for f in fams]
        need = max(float(n.max()) for n in needs)
        if not np.isfinite(need):  # gravity alone is at the limit somewhere: no slower fixes it
            family, j = next(
                (f, int(np.argmax(~np.isfinite(n))))
                for f, n in zip(fams, needs, strict=True)
                if not np.isfinite(n).all()
            )
            lim = next(x for x in limits if x.name == family.joints[j])
            spare = (lim.effort or np.inf) - np.abs(dense.C[..., lim.iv]).max(axis=1)
            raise _stuck(path, dense, int(np.argmin(spare)), [lim])
        step = max(need, 1.0 + 1e-6)
        profile, factor = profile.slowed(step), factor * step
        worst = max(float(ratios(f, profile, dense.theta).max()) for f in fams)
        if worst <= 1.0:
            return profile, factor, worst
    raise _stuck(path, dense, 0, limits)


def _no_timing(
    path: WaypointPath, dense: PathSamples, K: np.ndarray, limits: list[JointLimit]
) -> InfeasiblePath:
    """The InfeasiblePath for a path TOPP-RA finds no timing for: where its controllable
    sets end (the last gridpoint from which it could not reach the end)."""
    failed = np.flatnonzero(~np.isfinite(np.asarray(K, dtype=float)).all(axis=1))
    return _stuck(path, dense, int(failed.max()) if failed.size else 0, limits)


def _stuck(
    path: WaypointPath, dense: PathSamples, i: int, limits: list[JointLimit]
) -> InfeasiblePath:
    """The InfeasiblePath at interval i of the grid: the joint (of `limits`) with the least
    torque to spare against gravity there."""
    i = min(max(i, 0), dense.s.shape[0] - 1)
    strong = [lim for lim in limits if lim.effort is not None]
    joint = None
    if strong:
        spare = [(lim.effort - np.abs(dense.C[i, :, lim.iv]).max()) / lim.effort for lim in strong]
        joint = strong[int(np.argmin(spare))].name
    s = float(dense.s[i, 0])
    k, fraction = path.where(s)
    named = f"joint '{joint}' " if joint else ""
    return InfeasiblePath(
        f"no timing can follow this path within the limits: {named}cannot "
        f"be held and moved {_where(path, s)}",
        joint=joint,
        waypoint=k,
        path_fraction=fraction,
        kind="effort",
    )


def _samples(
    robot: Robot, path: WaypointPath, profile: Profile, dt: float, max_samples: int
) -> tuple[np.ndarray, ...]:
    """The motion every dt from 0, and at its end: t, q, v = q' ṡ, a = q' s̈ + q'' ṡ², τ."""
    duration = profile.duration
    if not np.isfinite(duration):
        raise InvalidInput(
            "the timing of this path has no finite duration in float64 (are the limits or "
            "the waypoints extreme?)"
        )
    steps = np.floor(duration / dt)  # (inf where dt is tiny: a float, not yet an int)
    if steps + 2 > max_samples:
        raise TooManySamples(
            f"sample_dt: the motion lasts {duration:.6g} s, so this step "
            f"gives more than {max_samples} samples; give a larger "
            "sample_dt"
        )
    t = np.arange(int(steps) + 1) * dt
    if t.size == 1 or duration - t[-1] > 1e-9 * dt:
        t = np.append(t, duration)  # the end, and never only the start
    else:
        t[-1] = duration
    s, sd, sdd = profile.at_times(t)
    q, dq, ddq = path(s), path(s, 1), path(s, 2)
    v = dq * sd[:, None]
    a = dq * sdd[:, None] + ddq * (sd**2)[:, None]
    return t, q, v, a, rnea.inverse_dynamics(robot, q, v, a)
