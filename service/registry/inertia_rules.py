"""What no rigid body has: the rules every inertia check applies (uploads, the catalog's
warnings, `GET /v1/robots/{id}/model-check`), and the power-of-ten slip that explains a
violation.

A rigid body's rotational inertia about its centre of mass, I (3×3, kg·m², symmetric), has
principal moments λ₁ ≤ λ₂ ≤ λ₃ (its eigenvalues) with λᵢ = ∫ (r² − rᵢ²) dm ≥ 0 and
λ₁ + λ₂ − λ₃ = 2 ∫ r₃² dm ≥ 0 (the triangle inequality). The errors, each with a tolerance for
numbers written with a few significant digits:

- `negative_principal_moment`: λ₁ < −(1e-4 · max|λ| + 1e-12 kg·m²). Eigenvalue rounding of a
  tensor written with a few significant digits gives negatives of about 1e-16 · max|λ| (e.g.
  −2.5e-22 against 3e-6 on several quadruped bases): those pass.
- `triangle_inequality`: λ₁ + λ₂ < λ₃ − (1e-4 · (λ₁ + λ₂ + λ₃) + 1e-12 kg·m²), checked on
  tensors without a negative moment.
- `inertia_without_mass`: mass 0 and an inertia that is not 0 (no body has inertia without
  mass: the description meant a massless link, or lost the mass).

A suggestion: where exactly one of the six attributes of the `<inertia>` as written
(ixx, ixy, ixz, iyy, iyz, izz), multiplied by a power of ten 10ᵏ (k = −6 … 3, k ≠ 0), gives a
tensor without error, that attribute with the smallest |k| (then the smaller k) that does.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from decimal import Decimal

import numpy as np

NEGATIVE_REL_TOL = 1e-4  # of the largest principal moment
TRIANGLE_REL_TOL = 1e-4  # of the trace
ABS_TOL = 1e-12  # kg·m²
ATTRIBUTES = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
POWERS = tuple(k for k in range(-6, 4) if k != 0)  # 10ᵏ a suggestion may apply
ERROR_CODES = ("negative_principal_moment", "triangle_inequality", "inertia_without_mass")


@dataclass(frozen=True)
class InertiaError:
    """An error of one body's inertia: its code and what it is, in words (no link name)."""

    code: str
    what: str


def tensor(attributes: Mapping[str, float]) -> np.ndarray:
    """The symmetric 3×3 tensor (kg·m²) of the six attributes of an `<inertia>`."""
    a = attributes
    return np.array(
        [
            [a["ixx"], a["ixy"], a["ixz"]],
            [a["ixy"], a["iyy"], a["iyz"]],
            [a["ixz"], a["iyz"], a["izz"]],
        ],
        dtype=float,
    )


def principal_moments(inertia: np.ndarray) -> np.ndarray:
    """λ₁ ≤ λ₂ ≤ λ₃ (kg·m²), the eigenvalues of the symmetric 3×3 `inertia`."""
    return np.linalg.eigvalsh(np.asarray(inertia, dtype=float))


def inertia_error(mass: float, inertia: np.ndarray) -> InertiaError | None:
    """The error of a body of `mass` (kg) with rotational `inertia` (3×3, kg·m², about its
    centre of mass), or None: at most one, in the order of the module docstring."""
    moments = principal_moments(inertia)
    shown = ", ".join(f"{m:.6g}" for m in moments)
    largest = float(np.max(np.abs(moments)))
    if moments[0] < -(NEGATIVE_REL_TOL * largest + ABS_TOL):
        return InertiaError(
            "negative_principal_moment",
            f"inertia has a negative principal moment {moments[0]:.6g} kg·m² "
            f"(principal moments {shown}; largest {largest:.6g})",
        )
    a, b, c = moments
    trace = float(a + b + c)
    if a + b < c - (TRIANGLE_REL_TOL * abs(trace) + ABS_TOL):
        excess = (c - a - b) / c * 100
        return InertiaError(
            "triangle_inequality",
            f"principal moments {shown} kg·m² violate the triangle inequality "
            f"({a:.6g} + {b:.6g} < {c:.6g}, short by {excess:.3g} % of the largest)",
        )
    if mass == 0.0 and largest > ABS_TOL:
        return InertiaError(
            "inertia_without_mass",
            f"mass is 0 and the inertia is not (principal moments {shown} kg·m²)",
        )
    return None


def power_of_ten_fix(mass: float, attributes: Mapping[str, float]) -> tuple[str, float] | None:
    """(attribute, corrected value) when exactly one attribute of the `<inertia>` as written,
    scaled by one power of ten, removes the error of a body of `mass` (kg); else None."""
    fixes: list[tuple[str, float]] = []
    for name in ATTRIBUTES:
        if attributes[name] == 0.0:
            continue
        for k in sorted(POWERS, key=lambda k: (abs(k), k)):
            value = float(Decimal(repr(float(attributes[name]))).scaleb(k))
            if inertia_error(mass, tensor({**attributes, name: value})) is None:
                fixes.append((name, value))
                break
    return fixes[0] if len(fixes) == 1 else None
