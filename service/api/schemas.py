"""Request and response schemas: the OpenAPI document, with sizes and units in every field."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

Number = Annotated[float, Field(allow_inf_nan=False)]
JointArray = list[Number] | list[list[Number]]


def _joint_field(desc: str) -> Any:
    return Field(description=desc + " A 1-D array is one state; a 2-D array [N][n] is a batch "
                 "of N states, and every answer then gains a leading axis of length N.")


Q_DESC = ("Configuration q, length nq: rad for revolute joints, m for prismatic ones; a "
          "free-flyer base takes [x, y, z, qx, qy, qz, qw] (m, unit quaternion, scalar last), a "
          "continuous joint [cos θ, sin θ]. GET /v1/robots/{id} gives each joint's idx_q.")
V_DESC = ("Velocity v, length nv: rad/s or m/s; a free-flyer base takes 6 entries first "
          "(linear then angular, in the base frame).")
A_DESC = "Acceleration a, length nv: rad/s² or m/s² (free-flyer: linear then angular)."
TAU_DESC = "Generalized force τ, length nv: N·m for revolute joints, N for prismatic ones."


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)


class QRequest(_Strict):
    q: JointArray = _joint_field(Q_DESC)


class QVRequest(QRequest):
    v: JointArray = _joint_field(V_DESC)


class QVARequest(QVRequest):
    a: JointArray = _joint_field(A_DESC)


class QVTauRequest(QVRequest):
    tau: JointArray = _joint_field(TAU_DESC)


REQUEST_BY_INPUTS: dict[tuple[str, ...], type[QRequest]] = {
    ("q",): QRequest, ("q", "v"): QVRequest, ("q", "v", "a"): QVARequest,
    ("q", "v", "tau"): QVTauRequest,
}

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


ANSWER_BY_QUANTITY: dict[str, type[BaseModel]] = {
    "mass-matrix": MassMatrixAnswer, "gravity": GravityAnswer, "coriolis": CoriolisAnswer,
    "nonlinear-effects": NonlinearEffectsAnswer, "inverse-dynamics": InverseDynamicsAnswer,
    "forward-dynamics": ForwardDynamicsAnswer,
}


LockedJointValue = Number | Annotated[list[Number], Field(min_length=1, max_length=64)]
LOCKED_DESC = (
    "Joints to lock, by name (GET /v1/robots/{id} lists them), each at a position: a number "
    "(rad or m) for revolute and prismatic joints; an angle θ (rad) or [cos θ, sin θ] for "
    "continuous joints; [x, y, z, qx, qy, qz, qw] for a free-flyer; [x, y, θ] or "
    "[x, y, cos θ, sin θ] for a planar joint; [qx, qy, qz, qw] for a spherical one; the nq "
    "entries of q for any other. Values outside a revolute or prismatic joint's position limits "
    "are rejected (422 invalid_configuration). The locked joints leave q, v, a and τ; their "
    "bodies are welded where these positions put them.")
DESCRIPTION_LIMIT = 8 * 1024 * 1024


class UploadRequest(_Strict):
    urdf: str | None = Field(None, description="The URDF text (XML). Meshes are not read: "
                             "robodyn needs kinematics and inertias only. Give this or `mjcf`.",
                             max_length=DESCRIPTION_LIMIT)
    mjcf: str | None = Field(None, description="Instead of `urdf`: MJCF (MuJoCo XML) text, one "
                             "self-contained file (<include> is refused; meshes are not read). "
                             "A free joint on its top body is its root (served as "
                             "\"free-flyer\").", max_length=DESCRIPTION_LIMIT)
    root_joint: Literal["fixed", "free-flyer", "planar"] = Field(
        "fixed", description="How the root link attaches to the world. For MJCF, only a top "
        "body without joints gets a root joint; a top body with a free joint is free-flying.")
    name: str | None = Field(None, max_length=200, description="Optional label; defaults to "
                             "the description's robot/model name. Not part of the id.")
    gravity: list[Number] = Field([0.0, 0.0, -9.81], min_length=3, max_length=3,
                                  description="Gravity vector in the world frame, m/s².")
    inertia_check: Literal["reject", "warn"] = Field(
        "reject", description="What to do with physically implausible inertias (negative "
        "principal moment, triangle inequality violated): reject the upload (422) or store it "
        "and list the findings in `warnings`.")
    locked_joints: dict[str, LockedJointValue] | None = Field(
        None, max_length=1000, description=LOCKED_DESC + " With this, only the reduced model "
        "is stored (its id is that of reducing the full upload with POST .../reduce).")

    @model_validator(mode="after")
    def _one_description(self) -> UploadRequest:
        if (self.urdf is None) == (self.mjcf is None):
            raise ValueError("give exactly one of `urdf` and `mjcf`")
        return self


class ReduceRequest(_Strict):
    locked_joints: dict[str, LockedJointValue] = Field(
        min_length=1, max_length=1000, description=LOCKED_DESC)
    name: str | None = Field(None, max_length=200, description="Optional label; defaults to "
                             "the base robot's name + ' (reduced)'. Not part of the id.")


class ReducedFrom(BaseModel):
    robot: str = Field(description="Id of the robot this one was reduced from.")
    locked_joints: dict[str, list[float]] = Field(description="Each locked joint's entries of "
                                                  "the base robot's q.")


class Problem(BaseModel):
    """RFC 9457 problem details with a stable machine-readable `code`."""

    type: str = "about:blank"
    title: str
    status: int
    detail: str
    code: str


class JointInfo(BaseModel):
    name: str
    type: str = Field(description="revolute, continuous, prismatic, free_flyer, planar, ...")
    parent: str = Field(description="Name of the parent joint ('universe' for the world).")
    idx_q: int = Field(description="Index of the joint's first entry in q.")
    nq: int
    idx_v: int = Field(description="Index of the joint's first entry in v, a and τ.")
    nv: int
    lower: list[float | None] = Field(description="Lower position limits (nq entries); null "
                                      "when unbounded.")
    upper: list[float | None]
    velocity_limit: list[float | None] = Field(description="nv entries, rad/s or m/s.")
    effort_limit: list[float | None] = Field(description="nv entries, N·m or N.")
    armature: list[float] = Field(description="Rotor inertia reflected on the joint (nv "
                                  "entries), added to M's diagonal.")


class RobotSummary(BaseModel):
    id: str
    name: str
    source: Literal["catalog", "upload"]
    nq: int
    nv: int
    root_joint: str


class RobotList(BaseModel):
    robots: list[RobotSummary]
    unavailable: dict[str, str] = Field(description="Catalog robots this server could not "
                                        "load, with the reason.")


class RobotInfo(RobotSummary):
    gravity: list[float]
    total_mass: float = Field(description="kg")
    neutral_configuration: list[float]
    default_configuration: list[float] = Field(description="The posture example-robot-data's "
                                               "loader used as q0 (neutral when none).")
    reference_configurations: dict[str, list[float]]
    warnings: list[dict[str, str]] = Field(description="Physical findings in the description, "
                                           "each with code, element (link/joint), name, message.")
    joints: list[JointInfo]
    frames: list[dict[str, str]]
    reduced_from: ReducedFrom | None = Field(None, description="Present for a reduced model.")
