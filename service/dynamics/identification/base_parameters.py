"""Base parameters: the combinations of parameters that joint torques can reveal.

Many columns of the regressor [Y | F] are zero (a body's mass never acts on a vertical first
joint) or linear combinations of others (a body's mass is indistinguishable from the first
moments of its parent along the joint offset). Torques determine only

    β = θ_ind + K θ_dep      (θ = [π; friction], r = rank of the regressor)

where the independent columns `ind` and the matrix K come from the regressor A stacked over
random states (every structural dependency of the model holds at every state, so random states
reveal exactly those). The columns are taken in the parameters' order (body after body from
the base, friction last) and, scaled to unit norm, orthogonalized against those kept before them
(Gram-Schmidt, the QR decomposition of the kept columns): a column whose remainder is below
RANK_TOLERANCE is a combination of earlier ones (a column below DEAD_COLUMN × the largest is
zero). So each base parameter is headed by a parameter of the body nearest the base and
collects the later bodies' parameters that act like it, e.g. the planar arm's
"shoulder.Iyy + elbow.m" (the elbow's mass seen through the 1 m upper arm, l₁² m₂).
K solves A_ind K = A_dep (least squares, exact up to rounding), so that Y_dep = Y_ind K and
Y θ = Y_ind β.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg

RANK_TOLERANCE = 1e-7  # the remainder of a unit column that still counts as independent
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
        """Each base parameter in the full ones, e.g. the UR5's "shoulder_lift_joint.m_cz +
        0.425 elbow_joint.m + 0.425 wrist_1_joint.m + ..." (6 significant digits; terms of
        |coefficient| < COEFFICIENT_ZERO omitted)."""
        out = []
        for k, head in enumerate(self.independent):
            text = self.names[head]
            for d, col in enumerate(self.dependent):
                c = float(self.combination[k, d])
                if abs(c) < COEFFICIENT_ZERO:
                    continue
                sign = "-" if c < 0 else "+"
                size = abs(c)
                text += (
                    f" {sign} {self.names[col]}"
                    if abs(size - 1.0) < 1e-9
                    else f" {sign} {size:.6g} {self.names[col]}"
                )
            out.append(text)
        return out


def base_parameters(
    columns: Callable[[np.random.Generator, int], np.ndarray], names: list[str], states: int
) -> BaseParameters:
    """The base parameters of a regressor: `columns(rng, count)` gives the regressor stacked
    over `count` random states, shape (rows, n) with n = len(names)."""
    rng = np.random.default_rng(RANDOM_STATES_SEED)
    stack = columns(rng, states)
    norms = np.linalg.norm(stack, axis=0)
    live = norms > DEAD_COLUMN * norms.max(initial=0.0)
    basis = np.zeros((stack.shape[0], 0))
    independent = []
    for col in np.flatnonzero(live):
        unit = stack[:, col] / norms[col]
        for _ in range(2):  # Gram-Schmidt twice: orthogonal to working precision
            unit = unit - basis @ (basis.T @ unit)
        size = float(np.linalg.norm(unit))
        if size > RANK_TOLERANCE:
            independent.append(col)
            basis = np.column_stack([basis, unit / size])
    heads = np.array(independent, dtype=int)
    dependent = np.setdiff1d(np.arange(len(names)), heads)
    combination = np.zeros((heads.size, dependent.size))
    if heads.size and dependent.size:
        combination = scipy.linalg.lstsq(stack[:, heads], stack[:, dependent])[0]
        combination[np.abs(combination) < COEFFICIENT_ZERO] = 0.0
    return BaseParameters(
        names=list(names), independent=heads, dependent=dependent, combination=combination
    )


def random_states_count(columns: int, nv: int) -> int:
    """How many random states stack to at least 3 rows per column (at least 50)."""
    return max(50, math.ceil(3 * columns / max(nv, 1)))
