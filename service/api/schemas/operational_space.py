"""Request and answer schemas beyond the equation of motion: M⁻¹, energy, centre of mass, frame
Jacobians and operational-space dynamics, with sizes and units in every field.

Option defaults equal the keyword defaults of the computing functions
(`service.dynamics.frames`, `service.dynamics.operational_space`).
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from service.api.schemas.common import Matrix, OptionalVRequest, Vector

Scalar = float | list[float]

FRAME_DESC = (
    "Name of a frame of the model: a link, a joint or a fixed frame. The valid names "
    "are listed under `frames` of GET /v1/robots/{id}; an unknown name is a 422 "
    "`unknown_frame`."
)
REFERENCE_DESC = (
    "The coordinates of 6-vectors [linear; angular] (linear first): `local_world_aligned` "
    "(default) the world's axes at the frame's origin, linear part = velocity of the frame's "
    "origin in world coordinates; `local` the frame's own axes; `world` the world frame, linear "
    "part = velocity of the body point at the world origin (spatial velocity). As in Pinocchio."
)

ReferenceFrameField = Literal["world", "local", "local_world_aligned"]


class JacobianRequest(OptionalVRequest):
    frame: str = Field(min_length=1, max_length=1000, description=FRAME_DESC)
    reference_frame: ReferenceFrameField = Field("local_world_aligned", description=REFERENCE_DESC)


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


class MassMatrixInverseAnswer(BaseModel):
    mass_matrix_inverse: Matrix = Field(
        description="M(q)⁻¹, nv×nv symmetric positive definite, 1/(kg·m²) (1/kg on prismatic "
        "rows), by Pinocchio's computeMinverse; (N, nv, nv) for a batch."
    )


class EnergyAnswer(BaseModel):
    kinetic_energy: Scalar = Field(
        description="T = ½ vᵀ M(q) v in J (armature included); a list of N values for a batch."
    )
    potential_energy: Scalar = Field(
        description="U(q) = −Σ mᵢ g₀ᵀ cᵢ in J: gravitational "
        "potential of the bodies' centres of mass cᵢ, zero at "
        "the world origin; g(q) = ∂U/∂q."
    )
    mechanical_energy: Scalar = Field(
        description="T + U in J; d(T + U)/dt = vᵀ τ along any "
        "motion, τ the applied generalized force."
    )


class CenterOfMassAnswer(BaseModel):
    position: Vector = Field(
        description="Centre of mass c(q) of the whole robot, [x, y, z] in "
        "m in the world frame; (N, 3) for a batch."
    )
    velocity: Vector | None = Field(
        None, description="Only with v: ċ = J_c v, [3] in m/s in the world frame."
    )
    jacobian: Matrix = Field(description="J_c(q) = ∂c/∂q, 3×nv, m per unit of v.")


class JacobianAnswer(BaseModel):
    jacobian: Matrix = Field(
        description="Frame Jacobian J(q), 6×nv: rows [vx, vy, vz, ωx, ωy, ωz] (m/s and "
        "rad/s per unit of v) in `reference_frame`; the frame's velocity is J v."
    )
    jacobian_time_variation: Matrix | None = Field(
        None,
        description="Only with v: J̇(q, v) = dJ/dt, 6×nv; the frame's acceleration in "
        "`reference_frame` is J a + J̇ v.",
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
