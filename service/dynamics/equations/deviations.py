"""The standard deviations of the parametric form's p1 … pr on a robot made by identification.

Identification estimates the base parameters β = P θ of its regressor (θ = [π; friction], P
from `identification.base_parameters`) with a covariance Σ (r_β × r_β: the weighted least
squares', or the physically consistent fit's posterior). Each p_k of the equations is a
combination of the standard parameters, p_k = L_k · π (`parametric`: the row of its expression,
armature left out: identification takes it as known). When L_k is a combination of the
estimated ones, [L_k, 0] = cᵀ P (c solved by least squares; the remainder below `IN_SPAN` of
‖L_k‖), then p_k = c · β and

    var(p_k) = cᵀ Σ c,    std(p_k) = √(cᵀ Σ c)   (kg, kg·m or kg·m², as p_k).

Where the log did not determine p_k — c outside the functionals of β the rows excite
(`determined`: the weighted regressor's row space, singular values above its largest / 1e8) —
or L_k is no combination of identification's β, its standard deviation is unknown: None.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

IN_SPAN = 1e-6  # a remainder this small relative to the vector: it lies in the span


def _remainder(basis: np.ndarray, vector: np.ndarray) -> tuple[np.ndarray, float]:
    """(y, |basis y − vector| / |vector|): the least-squares solution and its remainder."""
    size = float(np.linalg.norm(vector))
    if basis.size == 0:
        return np.zeros(basis.shape[1]), 0.0 if size == 0.0 else 1.0
    y = np.linalg.lstsq(basis, vector, rcond=None)[0]
    rest = float(np.linalg.norm(basis @ y - vector))
    return y, (rest / size if size > 0.0 else 0.0)


def standard_deviations(
    rows: np.ndarray, inertial: int, uncertainty: Mapping[str, Any]
) -> list[float | None]:
    """Per row L_k of `rows` (r × standard parameters, the first `inertial` = 10 · bodies in
    identification's order, armature after), the standard deviation of L_k · π from
    identification's `uncertainty` (`identification.pipeline.uncertainty`), or None (see the
    module docstring)."""
    projection = np.asarray(uncertainty["projection"], dtype=float)
    covariance = np.asarray(uncertainty["covariance"], dtype=float)
    determined = np.asarray(uncertainty["determined"], dtype=float)
    if determined.ndim != 2:
        determined = determined.reshape(projection.shape[0], 0)
    out: list[float | None] = []
    for row in rows:
        target = np.zeros(projection.shape[1])
        target[:inertial] = row[:inertial]
        c, rest = _remainder(projection.T, target)
        if rest > IN_SPAN:
            out.append(None)
            continue
        _, outside = _remainder(determined, c)
        if outside > IN_SPAN:
            out.append(None)
            continue
        out.append(float(np.sqrt(max(float(c @ covariance @ c), 0.0))))
    return out
