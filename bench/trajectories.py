"""Benchmarks of the trajectory routes (comparison 8 of bench/run.py), each against an
in-process baseline measured in the same run:

- trajectory-check of 10,000 samples of a 7-DoF arm (xArm7) with their v and a, through the
  client (the binary form), against a Python loop over `pin.rnea` on the same samples reading
  each joint's wrench `data.f` as the check does for the joint loads (states/s; target
  ≥ 0.8); and, for information, the same samples without v and a (the spline: 4 evaluated
  points per interval, so 4 × the states);
- retime of a 6-waypoint UR5 path, against plain toppra on the same path (its velocity and
  torque constraints on RNEA, its automatic grid, its output sampled every 0.01 s), including
  robodyn's correction and dense check (s; target ≤ 5 ×: retime times the path within 1 % of
  the optimum on about 880 intervals, with the limits at 3 points of each and a verification
  at 9, and plain toppra on its automatic grid breaks the limits between its gridpoints).
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from typing import Any

import numpy as np

SAMPLES = 10_000
ARM = "xarm7"


def _registry(names: list[str]) -> Any:
    from service.registry import Registry

    registry = Registry(tempfile.mkdtemp(), names)
    registry.load()
    return registry


def arm_motion(model: Any, n: int = SAMPLES) -> dict[str, np.ndarray]:
    """n samples of a smooth 20 s motion of every joint, with v and a of its spline."""
    from scipy.interpolate import CubicSpline

    t = np.linspace(0.0, 20.0, n)
    phase = np.linspace(0.0, 2.0, model.nq)
    q = 0.8 * np.sin(0.5 * t[:, None] + phase[None, :])
    spline = CubicSpline(t, q)
    return {"t": t, "q": q, "v": spline(t, 1), "a": spline(t, 2)}


def ur5_waypoints() -> np.ndarray:
    return np.random.default_rng(2).uniform(-2.0, 2.0, size=(6, 6))


def check(
    url: str,
    rounds: int,
    median_of: Callable[[int, Callable[[], float]], float],
    row: Callable[..., None],
) -> None:
    import pinocchio as pin
    import robodyn

    print("8a. trajectory-check (xArm7, 10,000 samples)", flush=True)
    model = _registry([ARM]).get(ARM).model
    motion = arm_motion(model)
    data = model.createData()

    def loop() -> float:  # what the check computes: τ and each joint's wrench (data.f)
        start = time.perf_counter()
        out = np.empty((SAMPLES, model.nv))
        wrenches = np.empty((SAMPLES, model.njoints - 1, 6))
        for i in range(SAMPLES):
            out[i] = pin.rnea(model, data, motion["q"][i], motion["v"][i], motion["a"][i])
            wrenches[i] = [data.f[j].vector for j in range(1, model.njoints)]
        return time.perf_counter() - start

    variants = {
        "with v and a": {"v": motion["v"], "a": motion["a"]},
        "spline, 4 points per interval": {},
    }
    with robodyn.Client(url, timeout=300) as client:

        def served(arrays: dict[str, Any]) -> Callable[[], float]:
            def once() -> float:
                start = time.perf_counter()
                client.trajectory_check(ARM, motion["t"], motion["q"], **arrays)
                return time.perf_counter() - start

            return once

        base = SAMPLES / median_of(rounds, loop)
        for what, arrays in variants.items():
            served(arrays)()  # warm-up: the robot's model pool, the first batch
            target = "≥ 0.8" if what == "with v and a" else "info"
            row(
                f"trajectory-check of {SAMPLES:,} xArm7 samples ({what}) via client vs "
                "in-process loop over pin.rnea and data.f",
                SAMPLES / median_of(rounds, served(arrays)),
                base,
                "states/s",
                target,
            )


def plain_toppra(model: Any, waypoints: np.ndarray) -> float:
    """Plain toppra on the same path; returns its duration (s), its output sampled."""
    import pinocchio as pin
    import toppra
    import toppra.algorithm
    import toppra.constraint

    data = model.createData()
    knots = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(waypoints, axis=0), axis=1))])
    path = toppra.SplineInterpolator(knots, waypoints, bc_type="clamped")
    effort = model.effortLimit
    constraints = [
        toppra.constraint.JointVelocityConstraint(model.velocityLimit),
        toppra.constraint.JointTorqueConstraint(
            lambda q, v, a: pin.rnea(model, data, q, v, a),
            np.stack([-effort, effort], 1),
            np.zeros(model.nv),
            discretization_scheme=toppra.constraint.DiscretizationType.Interpolation,
        ),
    ]
    trajectory = toppra.algorithm.TOPPRA(
        constraints, path, solver_wrapper="seidel"
    ).compute_trajectory(0, 0)
    t = np.arange(0.0, trajectory.duration, 0.01)
    trajectory(t), trajectory(t, 1), trajectory(t, 2)
    return float(trajectory.duration)


def retime(
    url: str,
    rounds: int,
    median_of: Callable[[int, Callable[[], float]], float],
    row: Callable[..., None],
) -> None:
    import httpx

    print("8b. retime (UR5, 6 waypoints)", flush=True)
    model = _registry(["ur5"]).get("ur5").model
    waypoints = ur5_waypoints()

    def baseline() -> float:
        start = time.perf_counter()
        plain_toppra(model, waypoints)
        return time.perf_counter() - start

    with httpx.Client(base_url=url, timeout=300) as client:

        def served() -> float:
            start = time.perf_counter()
            response = client.post("/v1/robots/ur5/retime", json={"waypoints": waypoints.tolist()})
            response.raise_for_status()
            return time.perf_counter() - start

        served(), baseline()  # warm-up of both sides (imports, the model pool)

        row(
            "retime of a 6-waypoint UR5 path (with the correction and check) vs plain toppra "
            "in-process",
            1e3 * median_of(rounds, served),
            1e3 * median_of(rounds, baseline),
            "ms",
            "≤ 5",
        )
