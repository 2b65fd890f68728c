"""The solver rows of `constraints.Family` as a toppra constraint, in the solver's units.

A module of its own, imported only when a path is retimed: importing toppra imports matplotlib
(about 2 s), which a service that never retimes should not pay at start.

toppra's seidel solver works with absolute tolerances (1e-10, 1e-8) and bounds (|u|, |x| ≤
1e8), so its variables must be of order 1 whatever the path's length and the limits' size. The
rows are therefore written in units of the path and of its own speed: the path parameter
σ = s / L ∈ [0, 1] and the time unit T = L / √x̄, where x̄ (`path_speed_scale`) is the path's
typical largest squared speed ṡ² at zero path acceleration. Then X = (dσ/dτ)² = x / x̄ and
U = d²σ/dτ² = u L / x̄, and a row a u + b x + c ≤ 1 becomes (a x̄ / L) U + (b x̄) X + c ≤ 1.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from toppra.constraint import DiscretizationType, LinearConstraint

from service.errors import InvalidInput

ROW_ZERO = 1e-150  # a row whose ‖(a, b)‖ is below this (a rounded zero, squared) is constant


def path_speed_scale(b: np.ndarray, c: np.ndarray) -> float:
    """x̄ ((units of q / s)²): the median over the stages of the largest x = ṡ² that every row
    allows with u = 0, min over rows with b > 0 of (1 − c) / b; 1 where no row bounds x (rows
    (N + 1, R), in the units of s)."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        bound = np.where((b > 0.0) & (c < 1.0), (1.0 - c) / b, np.inf)
    per_stage = bound.min(axis=1)
    usable = per_stage[np.isfinite(per_stage) & (per_stage > 0.0)]
    return float(np.median(usable)) if usable.size else 1.0


class SampledRows(LinearConstraint):  # type: ignore[misc]
    """A toppra canonical linear constraint given directly by its rows: at stage i,
    a[i] u + b[i] x + c[i] ≤ 1 (F = I, g = 1, the same at every stage), a, b, c (N + 1, R)
    in the solver's units (module docstring)."""

    def __init__(self, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> None:
        super().__init__()
        # Each row divided by ‖(a, b)‖ (the same half-plane): the seidel solver's tolerances
        # are absolute, and rows of the size of q'² near a path's ends would fall under them.
        # Rows with ‖(a, b)‖ < ROW_ZERO (c ≤ 1, a constant) stay as they are, with a = b = 0.
        norm = np.hypot(a, b)
        live = norm >= ROW_ZERO
        scale = 1.0 / np.where(live, norm, 1.0)
        self.a, self.b = np.where(live, a * scale, 0.0), np.where(live, b * scale, 0.0)
        self.c = np.where(live, (c - 1.0) * scale + 1.0, c)
        if not (np.isfinite(self.a).all() and np.isfinite(self.b).all()):
            raise InvalidInput(
                "the path and the limits span too many orders of magnitude to be timed in "
                "float64 (are the waypoints or limits extreme?)"
            )
        self.identical = True
        self.set_discretization_type(DiscretizationType.Collocation)
        rows = a.shape[1]
        self.F = np.eye(rows)
        self.g = np.ones(rows)

    def compute_constraint_params(
        self, path: Any, gridpoints: np.ndarray, *args: Any, **kwargs: Any
    ) -> tuple[Any, ...]:
        if len(gridpoints) != self.a.shape[0]:
            raise ValueError("the rows were made for another grid")
        return self.a, self.b, self.c, self.F, self.g, None, None
