"""Request and response schemas: the OpenAPI document, with sizes and units in every field."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

Number = Annotated[float, Field(allow_inf_nan=False)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)


class UploadRequest(_Strict):
    urdf: str = Field(description="The URDF text (XML). Meshes are not read: robodyn needs "
                      "kinematics and inertias only.", max_length=8 * 1024 * 1024)
    root_joint: Literal["fixed", "free-flyer", "planar"] = Field(
        "fixed", description="How the root link attaches to the world.")
    name: str | None = Field(None, max_length=200, description="Optional label; defaults to "
                             "the URDF's robot name. Not part of the id.")
    gravity: list[Number] = Field([0.0, 0.0, -9.81], min_length=3, max_length=3,
                                  description="Gravity vector in the world frame, m/s².")
    inertia_check: Literal["reject", "warn"] = Field(
        "reject", description="What to do with physically implausible inertias (negative "
        "principal moment, triangle inequality violated): reject the upload (422) or store it "
        "and list the findings in `warnings`.")


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


class FrameInfo(BaseModel):
    name: str = Field(description="What `frame` takes in jacobian and operational-space "
                      "requests. Where a link and a joint share a name, the first frame of "
                      "that name in this list is meant.")
    type: str = Field(description="body (a link), joint (a moving joint), fixed_joint, "
                      "op_frame or sensor.")
    parent_joint: str = Field(description="The joint that carries the frame ('universe' for "
                              "frames fixed to the world).")


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
    frames: list[FrameInfo] = Field(description="Every frame of the model in model order "
                                    "(links, joints, fixed frames): the valid names for "
                                    "`frame` in jacobian and operational-space requests.")
