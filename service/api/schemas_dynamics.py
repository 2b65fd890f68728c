"""Request and answer schemas of the equation-of-motion endpoints, with sizes and units.

`REQUESTS` and `ANSWERS` map each endpoint path to its models. A request model's joint-space
fields (q, v, a, tau) are arrays; every other field is an option passed to the computation.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field

Number = Annotated[float, Field(allow_inf_nan=False)]
# A joint-space vector keyed by joint name (see service.joint_names): a number or a list per joint.
JointsByName = dict[Annotated[str, Field(max_length=256)], Number | list[Number]]
JointArray = list[Number] | list[list[Number]] | JointsByName | list[JointsByName]


def joint_field(desc: str, default: Any = ...) -> Any:
    return Field(default, description=desc + " A 1-D array is one state; a 2-D array [N][n] is "
                 "a batch of N states, and every answer then gains a leading axis of length N. "
                 "Instead of an array, an object keyed by joint name (every joint named once, "
                 "or some left out with `fill`; a number or a 1-list for a 1-dof joint, the "
                 "angle θ or [cos θ, sin θ] for a continuous joint's q, the joint's entries "
                 "for others), or a list of such objects for a batch.")


Q_DESC = ("Configuration q, length nq: rad for revolute joints, m for prismatic ones; a "
          "free-flyer base takes [x, y, z, qx, qy, qz, qw] (m, unit quaternion, scalar last), a "
          "continuous joint [cos θ, sin θ]. For a model uploaded as MJCF, q is MuJoCo's qpos "
          "(ball and free joint quaternions w first). GET /v1/robots/{id} gives each joint's "
          "idx_q.")
V_DESC = ("Velocity v, length nv: rad/s or m/s; a free-flyer base takes 6 entries first "
          "(linear then angular, in the base frame).")
A_DESC = "Acceleration a, length nv: rad/s² or m/s² (free-flyer: linear then angular)."
TAU_DESC = "Generalized force τ, length nv: N·m for revolute joints, N for prismatic ones."


class StrictRequest(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)


class QRequest(StrictRequest):
    q: JointArray = joint_field(Q_DESC)


class QVRequest(QRequest):
    v: JointArray = joint_field(V_DESC)


class QVARequest(QVRequest):
    a: JointArray = joint_field(A_DESC)


class QVTauRequest(QVRequest):
    tau: JointArray = joint_field(TAU_DESC)


Matrix = list[list[float]] | list[list[list[float]]]
Vector = list[float] | list[list[float]]


class MassMatrixAnswer(BaseModel):
    mass_matrix: Matrix = Field(description="M(q), nv×nv symmetric positive definite, kg·m² "
                                "(kg for prismatic rows); (N, nv, nv) for a batch.")


class GravityAnswer(BaseModel):
    gravity: Vector = Field(description="g(q), length nv, N·m or N: generalized gravity "
                            "torques, the gradient of the potential energy.")


class CoriolisAnswer(BaseModel):
    coriolis_matrix: Matrix = Field(description="C(q, v), nv×nv, with Ṁ = C + Cᵀ; N·m·s.")
    coriolis_forces: Vector = Field(description="C(q, v) v, length nv, N·m or N.")


class NonlinearEffectsAnswer(BaseModel):
    nonlinear_effects: Vector = Field(description="C(q, v) v + g(q), length nv, N·m or N.")


class InverseDynamicsAnswer(BaseModel):
    tau: Vector = Field(description="τ = M(q) a + C(q, v) v + g(q), length nv, N·m or N.")


class ForwardDynamicsAnswer(BaseModel):
    a: Vector = Field(description="a = M(q)⁻¹ (τ − C(q, v) v − g(q)), length nv, rad/s² or "
                      "m/s².")


REQUESTS: dict[str, type[StrictRequest]] = {
    "mass-matrix": QRequest, "gravity": QRequest, "coriolis": QVRequest,
    "nonlinear-effects": QVRequest, "inverse-dynamics": QVARequest,
    "forward-dynamics": QVTauRequest,
}

ANSWERS: dict[str, type[BaseModel]] = {
    "mass-matrix": MassMatrixAnswer, "gravity": GravityAnswer, "coriolis": CoriolisAnswer,
    "nonlinear-effects": NonlinearEffectsAnswer, "inverse-dynamics": InverseDynamicsAnswer,
    "forward-dynamics": ForwardDynamicsAnswer,
}
