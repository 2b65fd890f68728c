"""The geometric path through waypoints that `retime` times.

q(s), s ∈ [0, L]: the cubic spline through the waypoints w_0 … w_{K−1} (each nq numbers) with
zero derivative at both ends (`scipy.interpolate.CubicSpline`, bc_type="clamped"), whose knot
s_k is the cumulative joint-space Euclidean distance s_k = Σ_{i<k} ‖w_{i+1} − w_i‖ (rad or m,
mixed for mixed joints), so L is the length of the waypoint polygon. A waypoint equal to the
one before it adds no length and is skipped (the spline needs increasing knots); indices in
messages are the caller's.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from service.dynamics.trajectories.inputs import samples
from service.errors import InvalidInput

_SAME_POINT = 1e-12  # rad or m: consecutive waypoints closer than this are the same point
MAX_WAYPOINTS = 1000  # each spline segment gets at least one TOPP-RA interval


class WaypointPath:
    """q(s) and its path derivatives q'(s), q''(s) (s in the units of q)."""

    def __init__(self, waypoints: Any, nq: int) -> None:
        count = _count(waypoints)
        if count > MAX_WAYPOINTS:
            raise InvalidInput(
                f"waypoints has {count} rows; at most {MAX_WAYPOINTS} are timed in one request"
            )
        w = samples("waypoints", waypoints, count, nq, "nq", "waypoints")
        if w.shape[0] < 2:
            raise InvalidInput(f"waypoints has {w.shape[0]} row(s); a path needs at least 2")
        steps = np.linalg.norm(np.diff(w, axis=0), axis=1)
        keep = np.concatenate([[True], steps > _SAME_POINT])
        if keep.sum() < 2:
            raise InvalidInput("waypoints are all the same configuration: there is no path to time")
        self.waypoints = w
        self.indices = np.flatnonzero(keep)  # the caller's index of each knot
        self.knots = np.concatenate([[0.0], np.cumsum(steps[keep[1:]])])
        self.length = float(self.knots[-1])
        self.spline = CubicSpline(self.knots, w[keep], bc_type="clamped", axis=0)
        self._d1 = self.spline.derivative(1)
        self._d2 = self.spline.derivative(2)

    def __call__(self, s: np.ndarray, order: int = 0) -> np.ndarray:
        """q(s) (order 0), q'(s) (1) or q''(s) (2) at path positions s [n]: (n, nq)."""
        derivative: np.ndarray = (self.spline, self._d1, self._d2)[order](s)
        return derivative

    def where(self, s: float) -> tuple[int, float]:
        """(the caller's index of the waypoint that starts the segment holding s, the path
        fraction s / L)."""
        k = int(np.searchsorted(self.knots, s, side="right")) - 1
        k = min(max(k, 0), len(self.knots) - 2)
        return int(self.indices[k]), float(s / self.length)


def _count(waypoints: Any) -> int:
    try:
        return len(waypoints)
    except TypeError:
        raise InvalidInput("waypoints must be an array of configurations") from None
