"""Answer schemas of the dynamics derivatives (`service.dynamics.derivatives`), ∂τ/∂(q, v, a) and
∂a/∂(q, v, τ), with sizes and units; their requests are the common `QVARequest` and
`QVTauRequest`."""

from __future__ import annotations

from pydantic import BaseModel, Field

from service.api.schemas.common import Matrix

_TANGENT = (
    "∂/∂q is on the tangent space: nv columns, the derivative along "
    "q ⊕ δq = integrate(q, δq) (for a free-flyer, δq's first 6 entries are a linear then "
    "angular displacement in the base frame)."
)


class InverseDynamicsDerivativesAnswer(BaseModel):
    dtau_dq: Matrix = Field(
        description="∂τ/∂q, nv×nv, N·m/rad or N/m; " + _TANGENT + " (N, nv, nv) for a batch."
    )
    dtau_dv: Matrix = Field(description="∂τ/∂v, nv×nv, N·m·s/rad or N·s/m.")
    dtau_da: Matrix = Field(description="∂τ/∂a = M(q), nv×nv symmetric, kg·m² or kg.")


class ForwardDynamicsDerivativesAnswer(BaseModel):
    da_dq: Matrix = Field(
        description="∂a/∂q, nv×nv, 1/s² (rad/s² per rad); " + _TANGENT + " (N, nv, nv) for a batch."
    )
    da_dv: Matrix = Field(description="∂a/∂v, nv×nv, 1/s.")
    da_dtau: Matrix = Field(description="∂a/∂τ = M(q)⁻¹, nv×nv symmetric, 1/(kg·m²) or 1/kg.")
