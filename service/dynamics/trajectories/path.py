"""The geometric path through waypoints that `retime` times.

q(s), s ∈ [0, L]: the cubic spline through the waypoints w_0 … w_{K−1} (each nq numbers) with
zero derivative at both ends (`scipy.interpolate.CubicSpline`, bc_type="clamped"), whose knot
s_k is the cumulative joint-space Euclidean distance s_k = Σ_{i<k} ‖w_{i+1} − w_i‖ (rad or m,
mixed for mixed joints), so L is the length of the waypoint polygon.

Duplicate and near-duplicate waypoints are merged: a waypoint within SAME_POINT_FRACTION × L
of the waypoint kept before it (or within SAME_POINT, rad or m) is the same point and is
skipped — except the last, which then takes the place of the one kept before it, so that the
path ends where the caller's does. A spline knot that close to its neighbour would bend the
path within a millionth of its length: a corner the robot can only take at a standstill, and
which no sampling of the path resolves. Indices in messages are the caller's.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from service.dynamics.trajectories.inputs import samples
from service.errors import InvalidInput

SAME_POINT = 1e-12  # rad or m: consecutive waypoints closer than this are the same point
SAME_POINT_FRACTION = 1e-6  # of the polygon's length L: closer waypoints are merged
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
        keep = _distinct(w)
        if keep.size < 2:
            raise InvalidInput("waypoints are all the same configuration: there is no path to time")
        steps = distances(w[keep])
        knots = np.concatenate([[0.0], np.cumsum(steps)])
        if not np.isfinite(knots[-1]):
            raise InvalidInput(
                "waypoints: the path through them is too long to compute with (its length "
                "overflows float64)"
            )
        self.waypoints = w
        self.indices = keep  # the caller's index of each knot
        self.knots = knots
        self.length = float(knots[-1])
        # the spline in σ = s / L ∈ [0, 1]: the same curve, whose polynomial pieces never
        # raise s to the third power (which overflows for a path 1e103 long, and underflows
        # for one 1e-103 long)
        self.spline = CubicSpline(knots / self.length, w[keep], bc_type="clamped", axis=0)
        self._d1 = self.spline.derivative(1)
        self._d2 = self.spline.derivative(2)

    def __call__(self, s: np.ndarray, order: int = 0) -> np.ndarray:
        """q(s) (order 0), q'(s) (1) or q''(s) (2) at path positions s [n]: (n, nq); from
        the spline Q(σ) in σ = s / L, q⁽ᵏ⁾(s) = Q⁽ᵏ⁾(s / L) / Lᵏ."""
        value = (self.spline, self._d1, self._d2)[order](np.asarray(s, dtype=float) / self.length)
        for _ in range(order):  # one division at a time: L² alone may overflow
            value = value / self.length
        return np.asarray(value)

    def extremes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The exact smallest and largest value of every coordinate on every spline segment,
        and where each is (s): (low, s_low, high, s_high), each (K − 1, nq). On a segment the
        path is one cubic, so its extremes are at the segment's ends or where its derivative,
        a quadratic, vanishes inside it; the ends are the waypoints themselves."""
        c = self.spline.c  # (4, K − 1, nq): c0 h³ + c1 h² + c2 h + c3 on [σ_k, σ_k+1]
        width = np.diff(self.spline.x)[:, None]  # (K − 1, 1), in σ
        a, b, d = 3.0 * c[0], 2.0 * c[1], c[2]  # the derivative a h² + b h + d
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            root = np.sqrt(b * b - 4.0 * a * d)
            quadratic = np.abs(a) > 1e-14 * (np.abs(b) + np.abs(d))
            h1 = np.where(quadratic, (-b + root) / (2.0 * a), -d / b)
            h2 = np.where(quadratic, (-b - root) / (2.0 * a), np.nan)
        candidates = [np.zeros_like(a), np.broadcast_to(width, a.shape), h1, h2]
        values, places = [], []
        for h in candidates:
            inside = np.isfinite(h) & (h >= 0.0) & (h <= width)
            h = np.where(inside, h, 0.0)
            value = ((c[0] * h + c[1]) * h + c[2]) * h + c[3]
            values.append(np.where(inside, value, c[3]))
            places.append(self.spline.x[:-1, None] + h)
        values_arr, places_arr = np.stack(values), np.stack(places)
        # the ends exactly: the waypoints, not the cubic evaluated there
        kept = self.waypoints[self.indices]
        values_arr[0], values_arr[1] = kept[:-1], kept[1:]
        low, high = values_arr.argmin(axis=0), values_arr.argmax(axis=0)
        pick = np.indices(low.shape)
        return (
            values_arr[low, pick[0], pick[1]],
            places_arr[low, pick[0], pick[1]] * self.length,
            values_arr[high, pick[0], pick[1]],
            places_arr[high, pick[0], pick[1]] * self.length,
        )

    def where(self, s: float) -> tuple[int, float]:
        """(the caller's index of the waypoint that starts the segment holding s, the path
        fraction s / L)."""
        k = int(np.searchsorted(self.knots, s, side="right")) - 1
        k = min(max(k, 0), len(self.knots) - 2)
        return int(self.indices[k]), float(s / self.length)


def distances(w: np.ndarray) -> np.ndarray:
    """‖w_{i+1} − w_i‖ for the K rows of w (K − 1,), rad or m, computed without squaring the
    differences (so waypoints up to float64's range apart have a finite distance). A
    difference that itself overflows is an InvalidInput naming the waypoints."""
    with np.errstate(over="ignore", invalid="ignore"):
        d = np.diff(w, axis=0)
    bad = np.flatnonzero(~np.isfinite(d).all(axis=1))
    if bad.size:
        i = int(bad[0])
        raise InvalidInput(
            f"waypoints {i} and {i + 1} are too far apart to compute with (their difference "
            "overflows float64)"
        )
    big = np.abs(d).max(axis=1)
    unit = d / np.where(big > 0.0, big, 1.0)[:, None]
    return np.asarray(big * np.linalg.norm(unit, axis=1))


def _distinct(w: np.ndarray) -> np.ndarray:
    """The indices of the waypoints that remain after merging (module docstring)."""
    with np.errstate(over="ignore"):
        polygon = float(distances(w).sum())
    near = max(SAME_POINT, SAME_POINT_FRACTION * polygon) if np.isfinite(polygon) else SAME_POINT
    last = w.shape[0] - 1

    def apart(i: int, j: int) -> bool:
        return float(distances(w[[i, j]])[0]) > near

    kept = [0]
    for i in range(1, last):
        if apart(kept[-1], i):
            kept.append(i)
    while len(kept) > 1 and not apart(kept[-1], last):
        kept.pop()  # the path ends at the caller's last waypoint
    if apart(kept[-1], last):
        kept.append(last)
    return np.asarray(kept, dtype=int)


def _count(waypoints: Any) -> int:
    try:
        return len(waypoints)
    except TypeError:
        raise InvalidInput("waypoints must be an array of configurations") from None
