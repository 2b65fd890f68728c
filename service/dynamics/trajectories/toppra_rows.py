"""The solver rows of `constraints.Family` as a toppra constraint.

A module of its own, imported only when a path is retimed: importing toppra imports matplotlib
(about 2 s), which a service that never retimes should not pay at start.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from toppra.constraint import DiscretizationType, LinearConstraint


class SampledRows(LinearConstraint):  # type: ignore[misc]
    """A toppra canonical linear constraint given directly by its rows: at stage i,
    a[i] u + b[i] x + c[i] ≤ 1 (F = I, g = 1, the same at every stage), a, b, c (N + 1, R)."""

    def __init__(self, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> None:
        super().__init__()
        # Each row divided by ‖(a, b)‖ (the same half-plane): the seidel solver's tolerances
        # are absolute (1e-10), and rows of the size of q'² near a path's ends would fall
        # under them. Rows with a = b = 0 (c ≤ 1, a constant) stay as they are.
        norm = np.hypot(a, b)
        scale = np.where(norm > 0.0, 1.0 / np.where(norm > 0.0, norm, 1.0), 1.0)
        self.a, self.b = a * scale, b * scale
        self.c = (c - 1.0) * scale + 1.0
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
