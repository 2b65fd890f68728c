"""Answers of the trajectory routes: `TrajectoryCheck` (does a motion stay within the robot's
limits?) and `Retimed` (the time-optimal motion along a path), with their parts as named
tuples, and the checks of their options."""

from __future__ import annotations

import numbers
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

from robodyn.arrays import ArrayLike, joint_array
from robodyn.errors import InputError


def positive(name: str, value: Any) -> float:
    """A finite number > 0, as float; else InputError."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{name} must be a number, not {type(value).__name__}")
    number = float(value)
    if not np.isfinite(number) or number <= 0:
        raise InputError(f"{name} must be a finite number > 0, not {value!r}")
    return number


def times(value: ArrayLike) -> np.ndarray:
    """Sample times t (s): 1-D, finite, at least 2, strictly increasing."""
    t = joint_array("t", value)
    if t.ndim != 1:
        raise InputError(f"t must be 1-D (one time per sample), not {t.ndim}-D")
    if t.shape[0] < 2 or not (np.diff(t) > 0).all():
        raise InputError("t must hold at least 2 strictly increasing times")
    return np.ascontiguousarray(t, dtype=np.float64)


def acceleration_limits(value: Any) -> list[float | None] | None:
    """Joint acceleration limits (rad/s² or m/s²) as the request sends them: None, or one
    entry per joint, a finite number > 0 or None (or NaN) for no limit on that joint."""
    if value is None:
        return None
    entries = list(value) if not isinstance(value, np.ndarray) else value.tolist()
    out: list[float | None] = []
    for i, x in enumerate(entries):
        if x is None or (isinstance(x, numbers.Real) and np.isnan(float(x))):
            out.append(None)
            continue
        out.append(positive(f"acceleration[{i}]", x))
    return out


class JointCheck(NamedTuple):
    """One 1-DoF joint over the checked motion: its limits (after the scales; None where it
    has none), the peaks of |τ| (N·m or N), |v| (rad/s or m/s) and |a| (rad/s² or m/s²) and
    the extremes of q over every evaluated point, and the ratios peak ÷ limit (> 1:
    broken; the acceleration limit is the request's, None where it gives none). For sizing
    its motor and bearings: `rms_effort` √(∫ τ² dt ÷ duration) (N·m or N), `peak_power`
    max |τ v| (W), and the peaks of the wrench (f, n) the joint transmits to its child body,
    in the joint frame with s its unit axis: `peak_force` ‖f‖ (N), `peak_moment` ‖n‖ (N·m),
    `peak_axial_force` |f · s| (N) and `peak_bending_moment` ‖n − (n · s) s‖ (N·m) (None
    from a server that does not send them)."""

    name: str
    effort_limit: float | None
    peak_effort: float
    effort_ratio: float | None
    velocity_limit: float | None
    peak_velocity: float
    velocity_ratio: float | None
    lower: float | None
    upper: float | None
    min_position: float | None
    max_position: float | None
    acceleration_limit: float | None = None
    peak_acceleration: float | None = None
    acceleration_ratio: float | None = None
    rms_effort: float | None = None
    peak_power: float | None = None
    peak_force: float | None = None
    peak_moment: float | None = None
    peak_axial_force: float | None = None
    peak_bending_moment: float | None = None

    @classmethod
    def from_json(cls, body: Mapping[str, Any]) -> JointCheck:
        """From the answer's entry (members the client does not know are left out)."""
        return cls(**{k: body[k] for k in cls._fields if k in body})


class Violation(NamedTuple):
    """A run of evaluated points beyond a limit: the joint, the kind ("effort", "velocity",
    "acceleration" or "position"), the times of its first and last points (s), the value
    farthest beyond the limit and that (signed) limit."""

    joint: str
    kind: str
    t_start: float
    t_end: float
    worst: float
    limit: float


class Work(NamedTuple):
    """∫ max(τᵀv, 0) dt and ∫ min(τᵀv, 0) dt over the motion, J."""

    positive: float
    negative: float


class TrajectoryCheck(NamedTuple):
    """The check of a sampled motion: `feasible` (no limit broken at any evaluated point),
    `tau` and `v` at the samples (N, nv), `joints`, `violations` (by start time) and `work`."""

    feasible: bool
    tau: np.ndarray
    v: np.ndarray
    joints: list[JointCheck]
    violations: list[Violation]
    work: Work

    @classmethod
    def from_json(
        cls, body: Mapping[str, Any], batched: bool = True, rows: int | None = None
    ) -> TrajectoryCheck:
        return cls(
            bool(body["feasible"]),
            np.asarray(body["tau"], dtype=np.float64),
            np.asarray(body["v"], dtype=np.float64),
            [JointCheck.from_json(j) for j in body["joints"]],
            [Violation(**x) for x in body["violations"]],
            Work(**body["work"]),
        )


class Retimed(NamedTuple):
    """The time-optimal motion along a path: `duration` (s), samples `t` (M,), `q` (M, nq),
    `v`, `a`, `tau` (M, nv), and `check`, the trajectory check of those samples."""

    duration: float
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    tau: np.ndarray
    check: TrajectoryCheck

    @classmethod
    def from_json(
        cls, body: Mapping[str, Any], batched: bool = True, rows: int | None = None
    ) -> Retimed:
        t, q, v, a, tau = (
            np.asarray(body[k], dtype=np.float64) for k in ("t", "q", "v", "a", "tau")
        )
        return cls(
            float(body["duration"]), t, q, v, a, tau, TrajectoryCheck.from_json(body["check"])
        )
