"""What a trajectory check reports about a motion, gathered from its evaluated points chunk by
chunk (`MotionSummary.add`), so that no array of all the points is ever held.

Per 1-DoF joint (`limits.joint_limits`): the peaks of |τ|, |v| and |a| and the extremes of q
over every evaluated point, their ratios to the limits, and the violations with their time spans
(`limits.Violations`); for the motion: the work, the integrals over time of max(τᵀv, 0)
(positive, J) and min(τᵀv, 0) (negative, J) by the trapezoidal rule over the evaluated points.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from service.dynamics.trajectories.limits import JointLimit, Violations, joint_limits, slack
from service.errors import InvalidInput, NonFiniteResult
from service.registry.robot import Robot


class _Bounds:
    """One kind of limit of the joints that have it: their names, the column of each in the
    series, and the bounds (±inf where a joint has none on that side)."""

    def __init__(self, kind: str, limits: list[JointLimit], column: str, bounds: Any) -> None:
        pairs = [(lim, bounds(lim)) for lim in limits]
        kept = [(lim, b) for lim, b in pairs if b != (None, None)]
        self.kind = kind
        self.names = [lim.name for lim, _ in kept]
        self.columns = np.array([getattr(lim, column) for lim, _ in kept], dtype=int)
        self.lower = [b[0] for _, b in kept]
        self.upper = [b[1] for _, b in kept]
        self.low = np.array([-np.inf if x is None else x for x in self.lower])
        self.high = np.array([np.inf if x is None else x for x in self.upper])

    def beyond(self, series: np.ndarray) -> np.ndarray:
        """The indices (into `names`) of the joints whose values in `series` [n, columns]
        go beyond a bound (as `Violations` counts it) somewhere."""
        values = series[:, self.columns]
        over = ((values - self.high) > slack(self.high)) | ((self.low - values) > slack(self.low))
        return np.flatnonzero(over.any(axis=0))


class MotionSummary:
    """Peaks, extremes, violations and work of a motion whose evaluated points are given in
    consecutive chunks, in time order (`add`); at the end `joints()`,
    `violations.in_time_order()` and `total_work()`."""

    def __init__(
        self,
        robot: Robot,
        effort_scale: float,
        velocity_scale: float,
        acceleration: np.ndarray | None = None,
    ) -> None:
        self.limits = joint_limits(robot, effort_scale, velocity_scale, acceleration)
        count = len(self.limits)
        self._iv = np.array([lim.iv for lim in self.limits], dtype=int)
        self._positioned = [j for j, lim in enumerate(self.limits) if lim.positioned]
        self._iq = np.array([self.limits[j].iq for j in self._positioned], dtype=int)
        self.peak_effort, self.peak_velocity = np.zeros(count), np.zeros(count)
        self.peak_acceleration = np.zeros(count)
        self.min_position = np.full(len(self._positioned), np.inf)
        self.max_position = np.full(len(self._positioned), -np.inf)
        self.effort = _Bounds("effort", self.limits, "iv", lambda x: _symmetric(x.effort))
        self.velocity = _Bounds("velocity", self.limits, "iv", lambda x: _symmetric(x.velocity))
        self.acceleration = _Bounds(
            "acceleration", self.limits, "iv", lambda x: _symmetric(x.acceleration)
        )
        self.position = _Bounds(
            "position",
            [x for x in self.limits if x.positioned],
            "iq",
            lambda x: (x.lower, x.upper),
        )
        self.violations = Violations()
        self.work = {"positive": 0.0, "negative": 0.0}
        self._last: tuple[float, float] | None = None  # (t, τᵀv) of the last point so far

    def add(
        self, t: np.ndarray, q: np.ndarray, v: np.ndarray, a: np.ndarray, tau: np.ndarray
    ) -> None:
        """The next evaluated points: times t [n] (s), q [n, nq], v, a and τ [n, nv]."""
        if self._iv.size:
            for peak, series in (
                (self.peak_effort, tau),
                (self.peak_velocity, v),
                (self.peak_acceleration, a),
            ):
                np.maximum(peak, np.abs(series[:, self._iv]).max(axis=0), out=peak)
        if self._iq.size:
            positions = q[:, self._iq]
            np.minimum(self.min_position, positions.min(axis=0), out=self.min_position)
            np.maximum(self.max_position, positions.max(axis=0), out=self.max_position)
        self.violations.next_piece()
        for bounds, series in (
            (self.effort, tau),
            (self.velocity, v),
            (self.acceleration, a),
            (self.position, q),
        ):
            for j in bounds.beyond(series):
                self.violations.add(
                    bounds.names[j],
                    bounds.kind,
                    t,
                    series[:, bounds.columns[j]],
                    bounds.lower[j],
                    bounds.upper[j],
                )
        self._add_work(t, np.einsum("ij,ij->i", tau, v))

    def _add_work(self, t: np.ndarray, power: np.ndarray) -> None:
        with np.errstate(over="ignore", invalid="ignore"):
            if self._last is not None:  # the segment from the last chunk's end to this one
                t, power = (
                    np.concatenate([[self._last[0]], t]),
                    np.concatenate([[self._last[1]], power]),
                )
            self.work["positive"] += float(np.trapezoid(np.maximum(power, 0.0), t))
            self.work["negative"] += float(np.trapezoid(np.minimum(power, 0.0), t))
        self._last = (float(t[-1]), float(power[-1]))

    def joints(self) -> list[dict[str, Any]]:
        """Per 1-DoF joint: its limits (after the scales), peaks, extremes and ratios."""
        out = []
        extremes = dict(
            zip(
                self._positioned,
                zip(self.min_position, self.max_position, strict=True),
                strict=True,
            )
        )
        for j, lim in enumerate(self.limits):
            peak_effort, peak_velocity = float(self.peak_effort[j]), float(self.peak_velocity[j])
            peak_acceleration = float(self.peak_acceleration[j])
            low, high = extremes.get(j, (None, None))
            out.append(
                {
                    "name": lim.name,
                    "effort_limit": lim.effort,
                    "peak_effort": peak_effort,
                    "effort_ratio": _ratio(peak_effort, lim.effort, lim.name, "effort_scale"),
                    "velocity_limit": lim.velocity,
                    "peak_velocity": peak_velocity,
                    "velocity_ratio": _ratio(
                        peak_velocity, lim.velocity, lim.name, "velocity_scale"
                    ),
                    "acceleration_limit": lim.acceleration,
                    "peak_acceleration": peak_acceleration,
                    "acceleration_ratio": _ratio(
                        peak_acceleration, lim.acceleration, lim.name, "limits.acceleration"
                    ),
                    "lower": lim.lower,
                    "upper": lim.upper,
                    "min_position": None if low is None else float(low),
                    "max_position": None if high is None else float(high),
                }
            )
        return out

    def total_work(self) -> dict[str, float]:
        """The work (J), or NonFiniteResult when it overflows float64."""
        if not all(np.isfinite(w) for w in self.work.values()):
            raise NonFiniteResult(
                "trajectory-check: the work ∫ τᵀv dt of this motion overflows float64 (its "
                "torques, velocities or duration are too large to compute with)"
            )
        return dict(self.work)


def _symmetric(limit: float | None) -> tuple[float | None, float | None]:
    return (None, None) if limit is None else (-limit, limit)


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
