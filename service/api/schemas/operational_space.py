"""Request and answer schemas of operational-space dynamics: Khatib's Λ, J̄, μ and p of a
frame's task, with sizes and units in every field.

Option defaults equal the keyword defaults of `service.dynamics.operational_space`.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from service.api.schemas.common import Matrix, Vector
from service.api.schemas.frames import JacobianRequest

MAX_DAMPING = 1e150
"""The largest damping λ: λ² (added to J M⁻¹ Jᵀ) must stay a finite float64."""


class OperationalSpaceRequest(JacobianRequest):
    task: Literal["full", "linear", "angular"] = Field(
        "full",
        description="Task rows of the frame Jacobian: `full` all 6 [linear; angular] "
        "(k = 6), `linear` the 3 linear rows, `angular` the 3 angular rows (k = 3).",
    )
    damping: float = Field(
        0.0,
        ge=0.0,
        le=MAX_DAMPING,
        allow_inf_nan=False,
        description="Damping λ ≥ 0. With λ > 0, Λ = (J M⁻¹ Jᵀ + λ² I)⁻¹ (damped least squares) "
        "and a singular configuration is answered; with 0 (default) Λ = (J M⁻¹ Jᵀ)⁻¹ and a "
        "configuration where the smallest singular value of J M⁻¹ Jᵀ is at most 1e-8 times its "
        "largest is a 422 `singular_configuration`. λ² is added in the units of J M⁻¹ Jᵀ: "
        "1/kg on linear rows, 1/(kg·m²) on angular rows. At most 1e150 (λ² stays a finite "
        "float64).",
    )


class OperationalSpaceAnswer(BaseModel):
    inertia: Matrix = Field(
        description="Task-space inertia Λ = (J M⁻¹ Jᵀ)⁻¹ (or damped), "
        "k×k symmetric: kg on linear rows, kg·m² on angular rows."
    )
    jacobian: Matrix = Field(
        description="Task Jacobian J, k×nv: the `task` rows of the "
        "frame Jacobian in `reference_frame`."
    )
    dynamically_consistent_inverse: Matrix = Field(
        description="J̄ = M⁻¹ Jᵀ Λ, nv×k, the dynamically consistent generalized inverse "
        "(J J̄ = I without damping)."
    )
    gravity: Vector = Field(
        description="Task-space gravity p = J̄ᵀ g, length k, N (linear) and N·m (angular)."
    )
    coriolis: Vector | None = Field(
        None,
        description="Only with v: task-space Coriolis and "
        "centrifugal force μ = J̄ᵀ C v − Λ J̇ v, length k. With "
        "ẍ = J a + J̇ v and τ = Jᵀ F: Λ ẍ + μ + p = F.",
    )
