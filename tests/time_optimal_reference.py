"""The time-optimal timing of a path as a convex program, for the tests of retime and for
bench/: an independent reference of the optimum retime approaches (its own spline, its own
torque coefficients by `pin.rnea` point by point, its own discretization and solver).

The formulation of Verscheure, Demeulenaere, Swevers, De Schutter and Diehl, "Time-optimal
path tracking for robots: a convex optimization approach" (IEEE TAC 2009): along the path q(s)
(the clamped cubic spline through the waypoints, s the cumulative joint-space distance), with
b = ṡ² at the gridpoints s_0 … s_N of a uniform grid and a constant path acceleration
u_i = (b_{i+1} − b_i) / (2 Δ) on each interval, the duration is

    T = Σ_i 2 Δ / (√b_i + √b_{i+1})

— convex in b — and every limit is affine in (u_i, b), here imposed at each interval's
midpoint (b there the mean of its ends): |q'_j b^½| ≤ v_j, |q'_j u + q''_j b| ≤ a_j,
|A_j u + B_j b + C_j| ≤ τ_j with A = M q', B = M q'' + C(q, q') q', C = g(q). The variables
are b and u (tied by b_{i+1} − b_i = 2 Δ u_i) in units of a typical b̄ and b̄ / L, and
c_i ≤ √b_i; the program is solved by Clarabel through cvxpy. As the grid is refined its
optimum converges to the optimum of the continuous problem; `extrapolated_optimum` solves it on
N, 2N and 4N intervals and extrapolates (Richardson, with the order the three solutions show).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
import scipy.sparse as sparse
from scipy.interpolate import CubicSpline


@dataclass(frozen=True)
class PathLimits:
    """Per joint (nv): velocity, effort and acceleration limits, NaN where there is none."""

    velocity: np.ndarray
    effort: np.ndarray
    acceleration: np.ndarray


def model_limits(
    model: pin.Model,
    velocity_scale: float = 1.0,
    effort_scale: float = 1.0,
    acceleration: np.ndarray | None = None,
) -> PathLimits:
    """The model's velocity and effort limits × the scales (none where not > 0 and finite),
    and the joint acceleration limits given (NaN or None entries: none)."""

    def usable(values: np.ndarray, scale: float) -> np.ndarray:
        values = np.asarray(values, dtype=float)
        ok = np.isfinite(values) & (values > 0) & (values < 1e300)
        return np.where(ok, values * scale, np.nan)

    acc = np.full(model.nv, np.nan) if acceleration is None else acceleration
    acc = np.array([np.nan if x is None else float(x) for x in acc])
    return PathLimits(
        usable(model.velocityLimit, velocity_scale), usable(model.effortLimit, effort_scale), acc
    )


def waypoint_spline(waypoints: np.ndarray) -> CubicSpline:
    """The path: the clamped cubic spline through the waypoints by cumulative distance."""
    knots = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(waypoints, axis=0), axis=1))])
    return CubicSpline(knots, waypoints, bc_type="clamped")


def convex_optimum(
    model: pin.Model, waypoints: np.ndarray, limits: PathLimits, intervals: int
) -> float:
    """The optimal duration (s) of the discretized problem on `intervals` uniform intervals."""
    import cvxpy as cp

    spline = waypoint_spline(np.asarray(waypoints, dtype=float))
    length = float(spline.x[-1])
    n = intervals
    delta = length / n
    mid = (np.arange(n) + 0.5) * delta
    q, dq, ddq = spline(mid), spline(mid, 1), spline(mid, 2)
    data = model.createData()
    zero = np.zeros(model.nv)
    g = np.array([pin.rnea(model, data, q[i], zero, zero) for i in range(n)])
    A = np.array([pin.rnea(model, data, q[i], zero, dq[i]) for i in range(n)]) - g
    B = np.array([pin.rnea(model, data, q[i], dq[i], ddq[i]) for i in range(n)]) - g
    # b at the midpoints, a linear map of b at the gridpoints
    rows = np.arange(n)
    mean = sparse.csr_matrix(
        (np.full(2 * n, 0.5), (np.repeat(rows, 2), np.stack([rows, rows + 1], 1).ravel())),
        shape=(n, n + 1),
    )
    # every limit as lower ≤ (coefficient of u) u + (coefficient of b) b_mid ≤ upper, ÷ limit
    u_rows, b_rows, lowers, uppers = [], [], [], []
    for j in range(model.nv):
        for u_part, b_part, constant, high in (
            (np.zeros(n), dq[:, j] ** 2, np.zeros(n), limits.velocity[j] ** 2),
            (dq[:, j], ddq[:, j], np.zeros(n), limits.acceleration[j]),
            (A[:, j], B[:, j], g[:, j], limits.effort[j]),
        ):
            if np.isfinite(high):
                u_rows.append(u_part / high)
                b_rows.append(b_part / high)
                lowers.append(-1.0 - constant / high)
                uppers.append(1.0 - constant / high)
    U, Bm = np.array(u_rows), np.array(b_rows)  # (limits, n)
    low, high = np.array(lowers), np.array(uppers)
    # units: b̄, the median over the midpoints of the largest b the limits allow at u = 0, and
    # ū = b̄ / L; the solver's variables are then of order 1 whatever the path and limits
    with np.errstate(divide="ignore", invalid="ignore"):
        room = np.where(Bm > 0, high / Bm, np.where(Bm < 0, low / Bm, np.inf))
    allowed = room.min(axis=0)
    usable = allowed[np.isfinite(allowed) & (allowed > 0)]
    scale = float(np.median(usable)) if usable.size else 1.0
    count = U.shape[0]

    def solve(split: bool, unit: float) -> np.ndarray | None:
        """b at the gridpoints (in units of `unit`), or None where Clarabel fails; `split`:
        u as variables of their own (Verscheure et al.'s form), else u = Δb / (2Δ)."""
        beta = cp.Variable(n + 1)  # b / unit at the gridpoints
        c = cp.Variable(n + 1)  # √β
        Gb = sparse.vstack([sparse.diags(Bm[k] * unit) @ mean for k in range(count)])
        constraints = [beta >= 0, beta[0] == 0, beta[n] == 0, c >= 0, c <= cp.sqrt(beta)]
        if split:
            alpha = cp.Variable(n)  # u / (unit / L) on the intervals
            Gu = sparse.block_diag([sparse.diags(U[k] * unit / length) for k in range(count)])
            expression = Gu @ cp.hstack([alpha] * count) + Gb @ beta
            constraints.append(beta[1:] - beta[:-1] == (2.0 / n) * alpha)  # Δb = 2 Δ u
        else:
            slope = sparse.diags([-np.ones(n), np.ones(n)], [0, 1], shape=(n, n + 1))
            Gu = sparse.vstack(
                [sparse.diags(U[k] * unit / (2 * delta)) @ slope for k in range(count)]
            )
            expression = (Gu + Gb) @ beta
        constraints += [expression <= high.ravel(), expression >= low.ravel()]
        duration = cp.sum(cp.inv_pos(c[:-1] + c[1:])) / n  # × 2 L / √unit
        problem = cp.Problem(cp.Minimize(duration), constraints)
        with warnings.catch_warnings():
            # "optimal_inaccurate": Clarabel's reduced tolerances; on the paths measured such
            # a solution's duration differs from the accurate one's by about 2e-6 relative
            warnings.filterwarnings("ignore", "Solution may be inaccurate", UserWarning)
            try:
                problem.solve(solver=cp.CLARABEL)
            except cp.error.SolverError:
                return None
        if problem.status not in ("optimal", "optimal_inaccurate"):
            return None
        return np.asarray(beta.value) * unit

    # Clarabel fails now and then on one form of a path and solves another: the forms in turn
    for split, unit in ((True, scale), (False, scale), (False, 1.0)):
        b = solve(split, unit)
        if b is not None:
            break
    else:
        raise RuntimeError("Clarabel solved none of the forms of the convex program")
    # the duration of the solution itself (b at the gridpoints), not the solver's bound
    root = np.sqrt(np.maximum(b, 0.0))
    return float(np.sum(2 * delta / (root[:-1] + root[1:])))


def extrapolated_optimum(
    model: pin.Model, waypoints: np.ndarray, limits: PathLimits, intervals: int
) -> tuple[float, list[float]]:
    """The optimum of the continuous problem, extrapolated from the convex program on
    `intervals`, 2 × and 4 × as many intervals: T* = T₄ − (T₂ − T₄) / (2ᵖ − 1), the order p
    from the three (kept within [1, 2]); (T*, [T₁, T₂, T₄])."""
    durations = [convex_optimum(model, waypoints, limits, intervals * k) for k in (1, 2, 4)]
    t1, t2, t4 = durations
    if (t1 - t2) * (t2 - t4) > 0:
        order = float(np.clip(np.log2((t1 - t2) / (t2 - t4)), 1.0, 2.0))
    else:
        order = 2.0  # no monotone trend: the finest solution, barely corrected
    return t4 - (t2 - t4) / (2.0**order - 1.0), durations


def _box(model: pin.Model, fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """The middle of the position limits and `fraction` of their half range (at most 3)."""
    low, high = model.lowerPositionLimit, model.upperPositionLimit
    return (low + high) / 2, fraction * np.minimum((high - low) / 2, 3.0)


def random_path(model: pin.Model, rng: np.random.Generator, count: int) -> np.ndarray:
    """`count` waypoints drawn uniformly within 0.8 of the position limits (of ±3 at most)."""
    middle, half = _box(model, 0.8)
    return middle + half * rng.uniform(-1, 1, (count, model.nq))


def long_sweep(model: pin.Model, legs: int = 20) -> np.ndarray:
    """Back and forth `legs` times between two opposite corners of 0.9 of the limits."""
    middle, half = _box(model, 0.9)
    return np.array([middle - half if k % 2 == 0 else middle + half for k in range(legs + 1)])


def random_walk(model: pin.Model, rng: np.random.Generator, count: int = 300) -> np.ndarray:
    """`count` waypoints, each a normal step (σ = 0.15 rad or m per joint) from the one
    before, kept within 0.9 of the limits."""
    middle, half = _box(model, 0.9)
    walk = [middle.copy()]
    for _ in range(count - 1):
        walk.append(np.clip(walk[-1] + rng.normal(0, 0.15, model.nq), middle - half, middle + half))
    return np.array(walk)


def zigzag(model: pin.Model, count: int = 60, amplitude: float = 0.3) -> np.ndarray:
    """`count` waypoints alternating ± `amplitude` about the middle of the limits, on every
    other joint and the last two."""
    middle, _ = _box(model, 0.9)
    sign = np.where(np.arange(count) % 2 == 1, 1.0, -1.0)
    moving = np.zeros(model.nq)
    moving[::2] = 1.0
    moving[-2:] = 1.0
    return middle + amplitude * sign[:, None] * moving[None, :]
