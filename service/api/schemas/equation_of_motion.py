"""Request and answer schemas of the equation-of-motion endpoints, M(q) a + C(q, v) v + g(q) = τ,
with sizes and units. Joint-space answers (τ, a, g, C v, h) are `JointVector`: arrays, or with
`"joint_names": true` objects keyed by joint name."""

from __future__ import annotations

from pydantic import BaseModel, Field

from service.api.schemas.common import (
    BY_NAME,
    JointVector,
    Matrix,
    QVARequest,
    QVTauRequest,
)
from service.api.schemas.external_forces import ExternalForce, forces_field


class InverseDynamicsRequest(QVARequest):
    external_forces: list[ExternalForce] | None = forces_field()
    friction: bool = Field(
        False,
        description="Add the joints' friction torque, offset + "
        "coulomb sign(v) + viscous v: for a robot stored by identification "
        "(its RobotInfo lists `friction`); any other robot is a 422.",
    )
    loads: bool = Field(
        False,
        description="Also answer `joint_wrenches`: the wrench each moving joint transmits "
        "from its parent body to its child body (RNEA's data.f), with the payloads, external "
        "forces and friction of the request.",
    )


class ForwardDynamicsRequest(QVTauRequest):
    external_forces: list[ExternalForce] | None = forces_field()


class MassMatrixAnswer(BaseModel):
    mass_matrix: Matrix = Field(
        description="M(q), nv×nv symmetric positive definite, kg·m² "
        "(kg for prismatic rows); (N, nv, nv) for a batch."
    )


class GravityAnswer(BaseModel):
    gravity: JointVector = Field(
        description="g(q), length nv, N·m or N: generalized gravity "
        "torques, the gradient of the potential energy." + BY_NAME
    )


class CoriolisAnswer(BaseModel):
    coriolis_matrix: Matrix = Field(description="C(q, v), nv×nv, with Ṁ = C + Cᵀ; N·m·s.")
    coriolis_forces: JointVector = Field(description="C(q, v) v, length nv, N·m or N." + BY_NAME)


class NonlinearEffectsAnswer(BaseModel):
    nonlinear_effects: JointVector = Field(
        description="C(q, v) v + g(q), length nv, N·m or N." + BY_NAME
    )


class InverseDynamicsAnswer(BaseModel):
    tau: JointVector = Field(
        description="τ = M(q) a + C(q, v) v + g(q), length nv, N·m or N." + BY_NAME
    )
    joint_wrenches: list[list[float]] | list[list[list[float]]] | None = Field(
        None,
        description="With `loads`: [joints][6] per state ([N][joints][6] for a batch), one "
        "row per moving joint in model order (the joints of RobotInfo, the universe "
        "excluded): the wrench the joint transmits to its child body, force f (N) then "
        "moment n (N·m) about the joint frame's origin, in the joint frame's axes. For a "
        "1-DoF joint with unit axis s, τ = s · n (revolute) or s · f (prismatic), plus the "
        "armature's share; friction adds along s.",
    )


class ForwardDynamicsAnswer(BaseModel):
    a: JointVector = Field(
        description="a = M(q)⁻¹ (τ − C(q, v) v − g(q)), length nv, rad/s² or m/s²." + BY_NAME
    )
