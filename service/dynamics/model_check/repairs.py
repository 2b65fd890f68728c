"""Repairs of a link's inertial (mass always kept), in the link frame:

- `from_geometry`: the centre of mass and inertia become the geometry's with the declared mass
  spread uniformly: c = c_geometry, I = (m / V) J (`geometry.MassProperties`);
- `nearest_valid`: the centre of mass and the principal axes kept, the principal moments λ
  replaced by the closest triple (least squares) that a rigid body can have,
  argmin |λ' − λ|² subject to λ'ᵢ ≥ 0 and λ'ᵢ + λ'ⱼ ≥ λ'ₖ — a projection onto a convex cone
  of six homogeneous constraints, solved exactly by trying every set of active constraints
  (64) and keeping the closest feasible point; I = Q diag(λ') Qᵀ with I = Q diag(λ) Qᵀ.

A link with mass 0 (an `inertia_without_mass` error) gets inertia 0 either way: the only
inertia a massless body has.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from service.dynamics.model_check.link_geometry import LinkShape
from service.registry.link_descriptions import LinkDescription

# rows a of the constraints a · λ ≥ 0
_CONE = np.array(
    [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 1.0, -1.0],
        [1.0, -1.0, 1.0],
        [-1.0, 1.0, 1.0],
    ]
)


def nearest_valid_moments(moments: np.ndarray) -> np.ndarray:
    """The triple closest to `moments` (3,) with λᵢ ≥ 0 and λᵢ + λⱼ ≥ λₖ (kg·m²)."""
    lam = np.asarray(moments, dtype=float)
    scale = max(float(np.max(np.abs(lam))), 1e-300)
    best, best_distance = np.zeros(3), float(np.sum(lam**2))  # the apex is always feasible
    for count in range(0, 3):
        for rows in itertools.combinations(range(6), count):
            a = _CONE[list(rows)]
            if count and np.linalg.matrix_rank(a) < count:
                continue
            x = lam if not count else lam - a.T @ np.linalg.solve(a @ a.T, a @ lam)
            if np.all(_CONE @ x >= -1e-12 * scale):
                distance = float(np.sum((x - lam) ** 2))
                if distance < best_distance:
                    best, best_distance = x, distance
    return best


def nearest_valid(link: LinkDescription) -> tuple[np.ndarray, np.ndarray]:
    """(centre of mass, inertia) of the `nearest_valid` repair of `link`."""
    if link.mass == 0.0:
        return link.center_of_mass.copy(), np.zeros((3, 3))
    moments, axes = np.linalg.eigh(link.inertia)
    fixed = axes @ np.diag(nearest_valid_moments(moments)) @ axes.T
    return link.center_of_mass.copy(), (fixed + fixed.T) / 2.0


def from_geometry(link: LinkDescription, geometry: LinkShape) -> tuple[np.ndarray, np.ndarray]:
    """(centre of mass, inertia) of the `geometry` repair of `link`."""
    props = geometry.properties
    return props.center.copy(), props.inertia * (link.mass / props.volume)


def repair_record(
    link: LinkDescription, how: str, center: np.ndarray, inertia: np.ndarray
) -> dict[str, Any]:
    """A repair as stored and applied (`service.registry.link_inertias`): the link, how, its
    mass, the repaired centre of mass (m) and inertia (kg·m², about it, link axes), and the
    `declared` ones it replaces."""
    return {
        "link": link.name,
        "from": how,
        "mass": float(link.mass),
        "center_of_mass": [float(x) + 0.0 for x in center],
        "inertia": [[float(x) + 0.0 for x in row] for row in inertia],
        "declared": {
            "center_of_mass": [float(x) + 0.0 for x in link.center_of_mass],
            "inertia": [[float(x) + 0.0 for x in row] for row in link.inertia],
        },
    }
