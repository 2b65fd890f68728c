"""How close retime comes to the time-optimal motion, and how long it takes.

    .venv/bin/python bench/retime_optimality.py            # 40 random paths and 3 long ones
    .venv/bin/python bench/retime_optimality.py --quick    # 8 random paths and the long ones

The reference is the optimum of the continuous problem, independent of the service's code:
the convex program of Verscheure et al. (2009) on uniform grids of the same path (its own
spline and `pin.rnea`), solved by Clarabel on N, 2N and 4N intervals and extrapolated
(`tests/time_optimal_reference.py`; N = 1,000 for the random paths, 3,000 for the long ones).
The paths: random paths of 2 to 7 waypoints within 0.8 of the position limits of ur10, panda
(fingers held), xarm7 and ur5 (every third with acceleration limits of 6 rad/s²), and three long
ones: a 264 rad sweep of the ur10 (20 legs between opposite corners), a 300-waypoint random walk
of the panda, and a 60-waypoint zig-zag of the xarm7 with acceleration limits of 4 rad/s².
(The catalog has no iiwa; a random path whose spline leaves a position limit is skipped, and
the next seed drawn.) Per path it prints retime's duration over the optimum, TOPP-RA's
first answer over the optimum (before the correction), the largest value of a limited quantity
over its limit found by an independent re-check at 25 points per interval, and retime's wall
time in process (the machine's load included).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from service.dynamics.trajectories import retime
from service.errors import InfeasiblePath
from service.registry import Registry
from tests.time_optimal_reference import (
    extrapolated_optimum,
    long_sweep,
    model_limits,
    random_path,
    random_walk,
    waypoint_spline,
    zigzag,
)

ARMS = ["ur10", "panda", "xarm7", "ur5"]


def recheck(model: pin.Model, waypoints: np.ndarray, result, limits, points: int = 24) -> float:
    """The largest |v|, |a|, |τ| over its limit at `points` + 1 points of every interval of
    the timing, by this script's own spline, chain rule and `pin.rnea`."""
    spline = waypoint_spline(waypoints)
    grid, x = result.profile.gridpoints, result.profile.x
    delta = np.diff(grid)[:, None]
    u = np.diff(x)[:, None] / (2 * delta)
    theta = np.linspace(0.0, 1.0, points + 1)[None, :]
    s = (grid[:-1, None] + theta * delta).ravel()
    speed2 = np.maximum(x[:-1, None] + 2 * theta * delta * u, 0.0).ravel()[:, None]
    accel = np.broadcast_to(u, (len(delta), theta.size)).ravel()[:, None]
    q, dq, ddq = spline(s), spline(s, 1), spline(s, 2)
    v, a = dq * np.sqrt(speed2), dq * accel + ddq * speed2
    data = model.createData()
    tau = np.array([pin.rnea(model, data, q[i], v[i], a[i]) for i in range(len(s))])
    worst = 0.0
    for values, limit in ((v, limits.velocity), (a, limits.acceleration), (tau, limits.effort)):
        bound = np.where(np.isfinite(limit), limit, np.inf)
        worst = max(worst, float((np.abs(values) / bound).max()))
    return worst


def cases(registry: Registry, per_arm: int) -> list[tuple[str, str, np.ndarray, list | None, int]]:
    """(name, robot, waypoints, acceleration limits, reference intervals)."""
    out = []
    for arm in ARMS:
        robot = registry.get(arm)
        seed, kept = 0, 0
        while kept < per_arm:
            rng = np.random.default_rng(seed)
            waypoints = random_path(robot.model, rng, int(rng.integers(2, 8)))
            if arm == "panda":
                waypoints[:, 7:] = 0.02
            acceleration = [6.0] * robot.model.nv if kept % 3 == 2 else None
            seed += 1
            try:
                retime(robot, waypoints, acceleration=acceleration, sample_dt=1.0)
            except InfeasiblePath as infeasible:  # the spline leaves a position limit
                print(f"{arm} #{seed - 1}: skipped, {infeasible}", flush=True)
                continue
            out.append((f"{arm} #{seed - 1}", arm, waypoints, acceleration, 1000))
            kept += 1
    walk = random_walk(registry.get("panda").model, np.random.default_rng(5))
    walk[:, 7:] = 0.02
    out += [
        ("ur10 264 rad sweep", "ur10", long_sweep(registry.get("ur10").model), None, 3000),
        ("panda 300-waypoint walk", "panda", walk, None, 3000),
        (
            "xarm7 60-waypoint zig-zag",
            "xarm7",
            zigzag(registry.get("xarm7").model),
            [4.0] * 7,
            3000,
        ),
    ]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="2 random paths per arm")
    parser.add_argument(
        "--per-arm", type=int, default=10, help="random paths per arm (0: the long ones only)"
    )
    args = parser.parse_args()
    per_arm = 2 if args.quick else args.per_arm
    registry = Registry(tempfile.mkdtemp(), ARMS)
    registry.load()
    print(f"{'path':28s} {'retime/opt':>10s} {'TOPP-RA/opt':>11s} {'worst':>9s} {'time':>7s}")
    ratios: dict[str, list[float]] = {"random": [], "long": []}
    times: dict[str, list[float]] = {"random": [], "long": []}
    for name, arm, waypoints, acceleration, intervals in cases(registry, per_arm):
        robot = registry.get(arm)
        start = time.perf_counter()
        result = retime(robot, waypoints, acceleration=acceleration)
        elapsed = time.perf_counter() - start
        limits = model_limits(robot.model, acceleration=acceleration)
        optimum, _ = extrapolated_optimum(robot.model, waypoints, limits, intervals)
        worst = recheck(robot.model, waypoints, result, limits)
        kind = "long" if intervals > 1000 else "random"
        ratios[kind].append(result.duration / optimum)
        times[kind].append(elapsed)
        print(
            f"{name:28s} {result.duration / optimum:10.5f} "
            f"{result.toppra_duration / optimum:11.5f} {worst:9.6f} {elapsed:6.2f}s",
            flush=True,
        )
    for kind in ("random", "long"):
        r, t = ratios[kind], times[kind]
        if not r:
            continue
        print(
            f"{kind} paths ({len(r)}): over the optimum median "
            f"{100 * (statistics.median(r) - 1):.2f} %, worst {100 * (max(r) - 1):.2f} %; "
            f"retime {min(t):.2f}–{max(t):.2f} s"
        )


if __name__ == "__main__":
    main()
