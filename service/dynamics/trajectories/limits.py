"""The limits a motion is checked against, and the time spans where a series breaks them.

A limit belongs to a 1-DoF joint (nv = 1: revolute, prismatic, continuous): its effort limit
|τ| ≤ τ_max (N·m or N), velocity limit |v| ≤ v_max (rad/s or m/s), position limits
lower ≤ q ≤ upper (rad or m; none for a continuous joint, whose q is (cos θ, sin θ)), and the
acceleration limit |a| ≤ a_max (rad/s² or m/s²) a request gives (models carry none). A model
value that is not a usable bound (non-finite, ≤ 0 for effort and velocity, |x| ≥ 1e300 for
positions, or lower = upper: URDF's "unset" conventions) is no limit (None).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from service.registry.robot import Robot, joint_type

_NO_LIMIT = 1e300  # a bound at least this large is "no bound" (Pinocchio's ±max float)
VIOLATION_TOLERANCE = 1e-9  # relative: a value counts as over its limit beyond limit·(1 + this)


def _magnitude_limit(value: float, scale: float) -> float | None:
    """A usable effort or velocity limit (times `scale`), else None."""
    if not math.isfinite(value) or value <= 0.0 or value >= _NO_LIMIT:
        return None
    return float(value) * scale


def _position_bound(value: float) -> float | None:
    return float(value) if math.isfinite(value) and abs(value) < _NO_LIMIT else None


@dataclass(frozen=True)
class JointLimit:
    """The limits of one 1-DoF joint: its index in q (`iq`) and in v (`iv`), effort and velocity
    limits after the request's scales, position bounds, the acceleration limit the request
    gives (None where there is none);
    `positioned`: q[iq] is the joint's position (revolute, prismatic; not continuous)."""

    name: str
    iq: int
    iv: int
    effort: float | None
    velocity: float | None
    lower: float | None
    upper: float | None
    positioned: bool
    acceleration: float | None = None


def joint_limits(
    robot: Robot,
    effort_scale: float = 1.0,
    velocity_scale: float = 1.0,
    acceleration: np.ndarray | None = None,
) -> list[JointLimit]:
    """The limits of every 1-DoF joint of `robot`, in model order; effort limits × effort_scale,
    velocity limits × velocity_scale (fractions of the model's limits), and the acceleration
    limits `acceleration` [nv] (inf or absent: none)."""
    m = robot.model
    out = []
    for jid in range(1, m.njoints):
        joint = m.joints[jid]
        if joint.nv != 1:
            continue
        iq, iv = int(joint.idx_q), int(joint.idx_v)
        positioned = joint.nq == 1 and joint_type(joint) != "continuous"
        lower, upper = float(m.lowerPositionLimit[iq]), float(m.upperPositionLimit[iq])
        bounded = positioned and lower < upper  # equal bounds: URDF's unset <limit> (0, 0)
        out.append(
            JointLimit(
                name=str(m.names[jid]),
                iq=iq,
                iv=iv,
                effort=_magnitude_limit(float(m.effortLimit[iv]), effort_scale),
                velocity=_magnitude_limit(float(m.velocityLimit[iv]), velocity_scale),
                lower=_position_bound(lower) if bounded else None,
                upper=_position_bound(upper) if bounded else None,
                positioned=positioned,
                acceleration=(
                    float(acceleration[iv])
                    if acceleration is not None and np.isfinite(acceleration[iv])
                    else None
                ),
            )
        )
    return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) indices of every run of consecutive True entries of a 1-D mask."""
    if not mask.any():
        return []
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1) - 1
    return list(zip(starts.tolist(), stops.tolist(), strict=True))


class Violations:
    """The violations of limits by series given in consecutive pieces (a check's chunks of
    evaluated points): one entry per run of consecutive points beyond a bound (by more than
    VIOLATION_TOLERANCE relative), with the joint, the kind, `t_start`/`t_end` the times of the
    run's first and last points, `worst` the value farthest beyond the bound and `limit` that
    (signed) bound. A run that reaches the end of one piece and goes on at the start of the
    next is one entry."""

    def __init__(self) -> None:
        self.found: list[dict[str, Any]] = []
        self._open: dict[tuple[str, str, float], dict[str, Any]] = {}  # runs at a piece's end
        self._carried: dict[tuple[str, str, float], dict[str, Any]] = {}

    def next_piece(self) -> None:
        """Start a piece: the runs open at the end of the last one may go on at its start."""
        self._carried, self._open = self._open, {}

    def add(
        self,
        joint: str,
        kind: str,
        t: np.ndarray,
        values: np.ndarray,
        lower: float | None,
        upper: float | None,
    ) -> None:
        """The runs of the series `values` [n] at times `t` [n] (s) of this piece beyond
        lower ≤ values ≤ upper."""
        for bound, sign in ((upper, 1.0), (lower, -1.0)):
            if bound is None:
                continue
            key = (joint, kind, sign)
            for first, last in _runs(sign * (values - bound) > slack(bound)):
                run = values[first : last + 1]
                worst = float(run[np.argmax(sign * run)])
                entry = self._carried.get(key) if first == 0 else None
                if entry is None:
                    entry = {
                        "joint": joint,
                        "kind": kind,
                        "t_start": float(t[first]),
                        "t_end": float(t[last]),
                        "worst": worst,
                        "limit": float(bound),
                    }
                    self.found.append(entry)
                else:
                    entry["t_end"] = float(t[last])
                    if sign * worst > sign * entry["worst"]:
                        entry["worst"] = worst
                if last == values.size - 1:
                    self._open[key] = entry

    def in_time_order(self) -> list[dict[str, Any]]:
        """Every violation, by start time (then joint and kind)."""
        return sorted(self.found, key=lambda x: (x["t_start"], x["joint"], x["kind"]))


def slack(bound: Any) -> Any:
    """How far beyond `bound` (a number or an array of them) a value is over it."""
    return VIOLATION_TOLERANCE * np.maximum(np.abs(bound), 1e-12)
