"""Answer schemas of the Lagrangian quantities (`service.dynamics.lagrangian`): M(q)⁻¹, the
energies and the centre of mass, with sizes and units in every field. Their requests are the
common ones (`QRequest`, `QVRequest`, `OptionalVRequest`)."""

from __future__ import annotations

from pydantic import BaseModel, Field

from service.api.schemas.common import Matrix, Vector

Scalar = float | list[float]


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
