"""Base parameters: the combinations of parameters that joint torques can reveal.

Many columns of the regressor [Y | F] are zero (a body's mass never acts on a vertical first
joint) or linear combinations of others (a body's mass is indistinguishable from the first
moments of its parent along the joint offset). Torques determine only

    β = θ_ind + K θ_dep      (θ = [π; friction], r = rank of the regressor)

where the independent columns `ind` and the matrix K come from a QR decomposition with column
pivoting of the regressor stacked over random states (every structural dependency of the
model holds at every state, so random states reveal exactly those): with the columns scaled to
unit norm (columns below DEAD_COLUMN × the largest are zero), A P = Q R, rank r = the count of
|R_kk| > RANK_TOLERANCE · |R_00|, and K = R₁₁⁻¹ R₁₂ (rescaled), so that Y_dep = Y_ind K and
Y θ = Y_ind β.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg

RANK_TOLERANCE = 1e-9  # relative to the largest pivot of the unit-column random stack
COEFFICIENT_ZERO = 1e-10  # entries of K below this (in their units) are rounding noise
DEAD_COLUMN = 1e-10  # a column this small relative to the largest is rounding noise: zero
RANDOM_STATES_SEED = 0  # the base parameters of a robot are the same on every call


@dataclass(frozen=True)
class BaseParameters:
    """The base parameters of a regressor with columns named `names` (length n)."""

    names: list[str]
    independent: np.ndarray  # (r,) column indices whose parameters head each combination
    dependent: np.ndarray  # (n − r,) the others (zero columns included)
    combination: np.ndarray  # K (r, n − r): Y[:, dependent] = Y[:, independent] K

    @property
    def count(self) -> int:
        return len(self.independent)

    def projection(self) -> np.ndarray:
        """P (r, n) with β = P θ."""
        out = np.zeros((self.count, len(self.names)))
        out[np.arange(self.count), self.independent] = 1.0
        out[:, self.dependent] = self.combination
        return out

    def expressions(self) -> list[str]:
        """Each base parameter in the full ones, e.g.
        "panda_joint2.Izz + 0.0995 panda_joint3.m_cy - 0.316 panda_joint3.m" (6 significant
        digits; terms of |coefficient| < COEFFICIENT_ZERO omitted)."""
        out = []
        for k, head in enumerate(self.independent):
            text = self.names[head]
            for d, col in enumerate(self.dependent):
                c = float(self.combination[k, d])
                if abs(c) < COEFFICIENT_ZERO:
                    continue
                sign = "-" if c < 0 else "+"
                size = abs(c)
                text += f" {sign} {self.names[col]}" if abs(size - 1.0) < 1e-9 else \
                    f" {sign} {size:.6g} {self.names[col]}"
            out.append(text)
        return out


def base_parameters(columns: Callable[[np.random.Generator, int], np.ndarray],
                    names: list[str], states: int) -> BaseParameters:
    """The base parameters of a regressor: `columns(rng, count)` gives the regressor stacked
    over `count` random states, shape (rows, n) with n = len(names)."""
    rng = np.random.default_rng(RANDOM_STATES_SEED)
    stack = columns(rng, states)
    norms = np.linalg.norm(stack, axis=0)
    live = norms > DEAD_COLUMN * norms.max(initial=0.0)
    scale = np.where(live, norms, 1.0)
    unit = np.where(live, stack / scale, 0.0)
    _, r, pivots = scipy.linalg.qr(unit, mode="economic", pivoting=True)
    diagonal = np.abs(np.diag(r))
    rank = int(np.count_nonzero(diagonal > RANK_TOLERANCE * diagonal[0])) if live.any() else 0
    independent, dependent = pivots[:rank], pivots[rank:]
    k_scaled = scipy.linalg.solve_triangular(r[:rank, :rank], r[:rank, rank:])
    combination = k_scaled * scale[dependent][np.newaxis, :] / scale[independent][:, np.newaxis]
    combination[np.abs(combination) < COEFFICIENT_ZERO] = 0.0
    order = np.argsort(independent, kind="stable")  # combinations in the parameters' order
    return BaseParameters(names=list(names), independent=independent[order],
                          dependent=np.sort(dependent),
                          combination=combination[order][:, np.argsort(dependent)])


def random_states_count(columns: int, nv: int) -> int:
    """How many random states stack to at least 3 rows per column (at least 50)."""
    return max(50, math.ceil(3 * columns / max(nv, 1)))
