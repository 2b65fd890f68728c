"""The points a trajectory check evaluates, with q, v and a there, chunk by chunk.

N samples at times t [N] (s) with q [N, nq]. Where v and a are both absent they are the
derivatives of the cubic spline through (t, q) (`SampleSpline`: not-a-knot, clamped — zero
velocity at both ends, a motion from rest to rest — or natural — zero acceleration at both
ends), and with
k = samples_per_interval the check also evaluates k − 1 evenly spaced points inside every
interval: (N − 1) k + 1 points in time order, sample i at point i·k (`evaluation_times`).
Otherwise the N samples are the points (a missing v or a is the spline's, at the samples).

`chunks` gives the points in chunks of whole intervals, so a check holds the samples (and the
spline's coefficients) whole but never all of its points: its memory does not grow with
samples_per_interval.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from service.errors import InvalidInput

SPLINE_COLUMNS = 16  # coordinates fitted at once (the fit's solve holds ~10 arrays of them)
BOUNDARIES = ("not-a-knot", "clamped", "natural")  # scipy's bc_type of the same names


def evaluated_points(samples: int, samples_per_interval: int, spline: bool) -> int:
    """The points a check of N `samples` evaluates: (N − 1) k + 1 where v and a come from the
    spline (`spline`), else the N samples."""
    return (samples - 1) * samples_per_interval + 1 if spline else samples


def evaluation_times(t: np.ndarray, k: int, start: int = 0, stop: int | None = None) -> np.ndarray:
    """The times of the points of the intervals start ≤ i < stop (default: all N − 1) of the
    sample times t [N]: t_i + (t_{i+1} − t_i) j / k for j = 0 … k − 1, and t_{N−1} when the
    last interval is among them; in increasing order (all: (N − 1) k + 1 times, sample i at
    index i·k)."""
    stop = t.size - 1 if stop is None else stop
    steps = np.arange(k) / k
    inner = t[start:stop, None] + (t[start + 1 : stop + 1] - t[start:stop])[:, None] * steps
    last = t[-1:] if stop == t.size - 1 else t[:0]
    return np.concatenate([inner.reshape(-1), last])


class SampleSpline:
    """The cubic spline through (t, q) with the end conditions `boundary` (one of BOUNDARIES,
    `scipy.interpolate.CubicSpline`'s bc_type), kept in the unit time τ = (t − t₀) / T
    (T the largest sample interval, τ built from the intervals), so that its pieces never
    raise t to the third power: q(t) = Q(τ), q̇ = Q'(τ) / T, q̈ = Q''(τ) / T². Fitted
    SPLINE_COLUMNS coordinates at a time (each coordinate's spline is its own). InvalidInput
    names the samples where q changes faster than float64 holds (Δq / Δt, or a derivative of
    the spline, overflows)."""

    def __init__(self, times: np.ndarray, qs: np.ndarray, boundary: str = "not-a-knot") -> None:
        steps = np.diff(times)
        self.times = times
        groups = [slice(c, c + SPLINE_COLUMNS) for c in range(0, qs.shape[1], SPLINE_COLUMNS)]
        bad = [self._first_overflow(qs[:, g], steps) for g in groups]
        first = min((i for i in bad if i is not None), default=None)
        if first is not None:
            raise self._too_fast(first, "velocity overflows")
        self.unit = float(steps.max())  # T, s
        self.tau = np.concatenate([[0.0], np.cumsum(steps / self.unit)])
        self.splines = [CubicSpline(self.tau, qs[:, g], bc_type=boundary, axis=0) for g in groups]

    @staticmethod
    def _first_overflow(q: np.ndarray, steps: np.ndarray) -> int | None:
        """The first interval where Δq / Δt of the coordinates q overflows, or None."""
        with np.errstate(over="ignore", invalid="ignore"):
            slopes = np.diff(q, axis=0) / steps[:, None]
        bad = np.flatnonzero(~np.isfinite(slopes).all(axis=1))
        return int(bad[0]) if bad.size else None

    def values(self, order: int, k: int, start: int = 0, stop: int | None = None) -> np.ndarray:
        """The `order`-th time derivative at the points of the intervals start ≤ i < stop
        (`evaluation_times` of the samples with k points per interval; k = 1: the samples)."""
        x = evaluation_times(self.tau, k, start, stop)
        with np.errstate(over="ignore", invalid="ignore", under="ignore"):
            values = np.concatenate([s(x, order) for s in self.splines], axis=1)
            for _ in range(order):  # one division at a time: T² alone may under- or overflow
                values = values / self.unit
        bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
        if bad.size:
            what = ("position", "velocity", "acceleration")[order]
            i = min(start + int(bad[0]) // k, self.times.size - 2)
            raise self._too_fast(i, f"spline's {what} overflows")
        return values

    def _too_fast(self, i: int, what: str) -> InvalidInput:
        return InvalidInput(
            f"t and q: between samples {i} and {i + 1} (t = {self.times[i]:.6g} s and "
            f"{self.times[i + 1]:.6g} s) q changes too fast to compute with for these times: "
            f"its {what} float64"
        )


@dataclass(frozen=True)
class Chunk:
    """Consecutive evaluated points: `first` (the index of the first among all points), their
    times `t` [n] (s), q [n, nq] (Pinocchio's order), v and a [n, nv]. Its rows
    `sample_rows` are the samples `samples` (the q given, exactly)."""

    first: int
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    sample_rows: slice
    samples: slice


def chunks(
    times: np.ndarray,
    qs: np.ndarray,
    vs: np.ndarray | None,
    acc: np.ndarray | None,
    spline: SampleSpline | None,
    k: int,
    size: int,
) -> Iterator[Chunk]:
    """The evaluated points of the samples (times [N], qs [N, nq], vs and acc [N, nv] or None
    where the `spline` gives them) in chunks of whole intervals, about `size` points each; with
    k > 1 (v and a both from the spline) the k − 1 points inside every interval too."""
    n = times.size
    per = max(1, size // k)  # intervals per chunk
    for start in range(0, n - 1, per):
        stop = min(start + per, n - 1)
        samples = slice(start, stop + 1 if stop == n - 1 else stop)
        if k > 1 and spline is not None:
            q = spline.values(0, k, start, stop)
            q[::k] = qs[samples]  # the samples exactly as given
            v, a = spline.values(1, k, start, stop), spline.values(2, k, start, stop)
        else:
            q = qs[samples]
            v = vs[samples] if vs is not None else _at_samples(spline, 1, start, stop)
            a = acc[samples] if acc is not None else _at_samples(spline, 2, start, stop)
        t = evaluation_times(times, k, start, stop)
        yield Chunk(start * k, t, q, v, a, slice(None, None, k), samples)


def _at_samples(spline: SampleSpline | None, order: int, start: int, stop: int) -> np.ndarray:
    """The spline's `order`-th derivative at the samples of intervals start ≤ i < stop."""
    assert spline is not None  # fitted by the caller wherever v or a is absent
    return spline.values(order, 1, start, stop)
