"""The limits of a timed path as TOPP-RA constraints, enforced at several points per interval.

Along a path q(s), with the path speed x = ṡ² and acceleration u = s̈, each limited quantity
is affine in (u, x):

    joint velocity²  q̇_j² = q'_j² x                     ≤ v_max²
    joint accel.     q̈_j = q'_j u + q''_j x             ∈ [−a_max, a_max]
    joint torque     τ_j = A_j u + B_j x + C_j           ∈ [−τ_max, τ_max]
                     (A = M q', B = M q'' + C(q, q') q', C = g: `rnea.path_coefficients`)

TOPP-RA chooses one u per interval [s_i, s_{i+1}], so x is linear inside it:
x(s_i + θΔ_i) = x_i + 2θΔ_i u. A quantity f = A u + B x + C at that point is then

    (A + 2θΔ_i B) u + B x_i + C

— still affine in the interval's own (u, x_i). toppra's interpolation discretization writes
this for θ = 0 and θ = 1; here it is written for θ = 0, 1/m, …, 1 (m + 1 points per
interval), so the solver itself keeps the limits inside the intervals. Each row is divided by
its limit (f / f_max ≤ 1): rows of every unit then weigh alike in the solver's tolerances.
A `Family` holds one limited quantity of every joint at those points; `tightening` (≤ 1) per
stage and joint shrinks the limit the solver sees, for the correction `retime` makes. The rows go to
toppra as `toppra_rows.SampledRows`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Family:
    """One limited quantity f = A u + B x + C of `joints` (names) at the points of every
    interval: A, B, C of shape (N, p, J) at θ [p] (θ[0] = 0, θ[-1] = 1), and per joint the
    upper bound `upper` [J] and lower bound `lower` [J] (None: no lower row, as for q̇²).
    `kind` is effort, velocity or acceleration; for velocity f is q̇² and the limit is
    v_max² (the answer's words use v_max)."""

    kind: str
    joints: list[str]
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    upper: np.ndarray
    lower: np.ndarray | None

    def values(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """f at every point for path speeds² x and accelerations u of shape (N, p): (N, p, J)."""
        f: np.ndarray = self.A * u[..., None] + self.B * x[..., None] + self.C
        return f

    def rows(
        self, theta: np.ndarray, deltas: np.ndarray, tightening: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The solver's rows a u + b x + c ≤ 1 per stage: arrays (N + 1, R), the limits × the
        `tightening` (≤ 1) per stage and joint, (N + 1, J) (or [J]: the same at every stage).
        Stage N (the last gridpoint) gets the rows of its own point, repeated (θ = 0 of a
        zero-length interval)."""
        a = self.A + 2.0 * theta[None, :, None] * deltas[:, None, None] * self.B
        coefficients = []
        for inner, end in ((a, self.A), (self.B, self.B), (self.C, self.C)):
            last = np.broadcast_to(end[-1:, -1:, :], (1, *inner.shape[1:]))
            coefficients.append(np.concatenate([inner, last]))  # (N + 1, p, J)
        shrink = np.asarray(tightening).reshape(-1, 1, len(self.joints))
        upper = self.upper * shrink
        out = []
        for f in coefficients:
            parts = [f / upper]
            if self.lower is not None:
                parts.append(-f / (-self.lower * shrink))
            out.append(np.concatenate(parts, axis=2).reshape(f.shape[0], -1))
        return out[0], out[1], out[2]
