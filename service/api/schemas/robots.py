"""Schemas of the robot routes: uploads, reductions, the robot list and a robot's description."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, Field, model_validator

from service.api.schemas.common import Number, RoutedRequest

LockedJointValue = Number | Annotated[list[Number], Field(min_length=1, max_length=64)]
LOCKED_DESC = (
    "Joints to lock, by name (GET /v1/robots/{id} lists them), each at a position: a number "
    "(rad or m) for revolute and prismatic joints; an angle θ (rad) or [cos θ, sin θ] for "
    "continuous joints; [x, y, z, qx, qy, qz, qw] for a free-flyer; [x, y, θ] or "
    "[x, y, cos θ, sin θ] for a planar joint; [qx, qy, qz, qw] for a spherical one "
    "([qw, qx, qy, qz], MuJoCo's order, for a model uploaded as MJCF); the nq "
    "entries of q for any other. Values outside a revolute or prismatic joint's position limits "
    "are rejected (422 invalid_configuration). The locked joints leave q, v, a and τ; their "
    "bodies are welded where these positions put them."
)
DESCRIPTION_LIMIT = 8 * 1024 * 1024


class UploadRequest(RoutedRequest):
    urdf: str | None = Field(
        None,
        description="The URDF text (XML). Give exactly one of "
        "`urdf`, `mjcf` and `xacro`; meshes (for the 3-D view) as "
        "`assets`.",
        max_length=DESCRIPTION_LIMIT,
    )
    mjcf: str | None = Field(
        None,
        description="Instead of `urdf`: MJCF (MuJoCo XML) text, "
        "compiled by MuJoCo itself (includes and meshes come from `assets`). "
        "q and v are MuJoCo's qpos and qvel, except that quaternions (ball "
        "and free joints) are x, y, z, w. A free joint is served as two "
        "joints: `<name>` (translation) and `<name>_rotation`.",
        max_length=DESCRIPTION_LIMIT,
    )
    root_joint: Literal["fixed", "free-flyer", "planar"] = Field(
        "fixed",
        description="How the root link attaches to the world. For MJCF, only a top "
        "body without joints gets a root joint; a top body with a free joint is free-flying.",
    )
    name: str | None = Field(
        None,
        max_length=200,
        description="Optional label; defaults to "
        "the description's robot/model name. Not part of the id.",
    )
    gravity: list[Number] | None = Field(
        None,
        min_length=3,
        max_length=3,
        description="Gravity vector in the world frame, m/s². "
        "Default: the MJCF's own `<option gravity>` (zero if its gravity flag is disabled); "
        "[0, 0, -9.81] for URDF.",
        examples=[[0.0, 0.0, -9.81]],
    )
    inertia_check: Literal["reject", "warn", "repair"] = Field(
        "reject",
        description="What to do with inertias no rigid body has (negative principal moment, "
        "triangle inequality violated, inertia without mass): reject the upload (422 naming "
        "the link, the numbers and a power-of-ten correction where one explains it), store "
        "it and list the findings in `warnings`, or repair each such link in the stored "
        "model (from its geometry where it has some, else the nearest valid tensor; each "
        "repair listed in `warnings` as `inertia_repaired`).",
    )
    locked_joints: dict[str, LockedJointValue] | None = Field(
        None,
        max_length=1000,
        description=LOCKED_DESC + " With this, only the reduced model "
        "is stored (its id is that of reducing the full upload with POST .../reduce).",
    )
    assets: dict[str, str] | None = Field(
        None,
        description="The files the description references, by the relative path it uses "
        "(`package://pkg/x.stl` matches `pkg/x.stl`; MJCF's meshdir is joined as MuJoCo joins "
        "it): path → the file's bytes in base64. Meshes (stl, obj, dae, glb, gltf, ply, msh), "
        "included MJCF or xacro files, YAML, PNG textures. Part of the model's id; stored with "
        "it; unreferenced ones are listed in `warnings`.",
    )

    xacro: str | None = Field(
        None,
        description="Instead of `urdf`: a xacro file, expanded by "
        "the service with ROS's xacro, with access to nothing but `assets` "
        "(`$(find pkg)` is the assets under `pkg/`).",
        max_length=DESCRIPTION_LIMIT,
    )
    xacro_args: dict[str, str] | None = Field(
        None,
        max_length=200,
        description="The xacro's arguments (`$(arg name)`), as strings. Part of the model's id.",
    )

    @model_validator(mode="after")
    def _one_description(self) -> UploadRequest:
        if sum(x is not None for x in (self.urdf, self.mjcf, self.xacro)) != 1:
            raise ValueError("give exactly one of `urdf`, `mjcf` and `xacro`")
        if self.xacro_args is not None and self.xacro is None:
            raise ValueError("`xacro_args` go with `xacro`")
        return self


class ReduceRequest(RoutedRequest):
    locked_joints: dict[str, LockedJointValue] = Field(
        min_length=1, max_length=1000, description=LOCKED_DESC
    )
    name: str | None = Field(
        None,
        max_length=200,
        description="Optional label; defaults to "
        "the base robot's name + ' (reduced)'. Not part of the id.",
    )


class ReducedFrom(BaseModel):
    robot: str = Field(description="Id of the robot this one was reduced from.")
    locked_joints: dict[str, list[float]] = Field(
        description="Each locked joint's entries of the base robot's q."
    )


class JointInfo(BaseModel):
    name: str
    type: str = Field(description="revolute, continuous, prismatic, free_flyer, planar, ...")
    parent: str = Field(description="Name of the parent joint ('universe' for the world).")
    idx_q: int = Field(description="Index of the joint's first entry in q.")
    nq: int
    idx_v: int = Field(description="Index of the joint's first entry in v, a and τ.")
    nv: int
    lower: list[float | None] = Field(
        description="Lower position limits (nq entries); null when unbounded."
    )
    upper: list[float | None]
    velocity_limit: list[float | None] = Field(description="nv entries, rad/s or m/s.")
    effort_limit: list[float | None] = Field(description="nv entries, N·m or N.")
    armature: list[float] = Field(
        description="Rotor inertia reflected on the joint (nv entries), added to M's diagonal."
    )


class ContactFrame(BaseModel):
    frame: str = Field(description="A frame the robot stands on (a foot or a sole).")
    type: str = Field(description="`point` (a point foot) or `6d` (a flat sole).")


class FrameInfo(BaseModel):
    name: str = Field(
        description="What `frame` takes in jacobian and operational-space "
        "requests. Where a link and a joint share a name, the first frame of "
        "that name in this list is meant."
    )
    type: str = Field(
        description="body (a link), joint (a moving joint), fixed_joint, op_frame or sensor."
    )
    parent_joint: str = Field(
        description="The joint that carries the frame ('universe' for frames fixed to the world)."
    )


class RobotSummary(BaseModel):
    id: str
    name: str
    source: Literal["catalog", "upload"]
    nq: int
    nv: int
    root_joint: str


class RobotList(BaseModel):
    robots: list[RobotSummary] = Field(
        description="A page of the list: the catalog's robots in catalog order, then the "
        "stored models (uploads and variants) by id. The first page with the default `limit` "
        "holds every catalog robot."
    )
    unavailable: dict[str, str] = Field(
        description="Catalog robots this server could not load, with the reason."
    )
    next_cursor: str | None = Field(
        None,
        description="Where the next page starts: pass it as `cursor` (unchanged; it is "
        "opaque). null on the last page.",
    )


class JointFriction(BaseModel):
    joint: str
    coulomb: float = Field(description="N·m (N): the Coulomb term's size, times sign(v).")
    viscous: float = Field(description="N·m·s/rad (N·s/m): times v.")
    offset: float = Field(description="N·m (N): a constant torque.")


class RobotInfo(RobotSummary):
    gravity: list[float]
    total_mass: float = Field(
        description="The mass the dynamics moves, kg: every body a joint "
        "moves (payloads of a variant included); links fixed to the world "
        "are not in it (see `fixed_mass`)."
    )
    moving_mass: float = Field(
        description="The same as `total_mass`, kg, under a name that says what it is."
    )
    fixed_mass: float = Field(
        description="The links fixed to the world, kg (a fixed-base "
        "robot's base link): no joint moves them, so they take no part "
        "in the dynamics. moving_mass + fixed_mass is the description's "
        "mass."
    )
    neutral_configuration: list[float]
    default_configuration: list[float] = Field(
        description="The posture example-robot-data's loader used as q0 (neutral when none)."
    )
    reference_configurations: dict[str, list[float]]
    warnings: list[dict[str, str]] = Field(
        description="Physical findings in the description and notes on its assets, each with "
        "code, element (link, joint or asset), name, message; `missing_mesh` (a mesh the "
        "visuals name that the upload lacks) adds `file`, the asset key it would have."
    )
    contact_frames: list[ContactFrame] = Field(
        default_factory=list,
        description="Suggested contacts for contact-dynamics, "
        "contact-inverse-dynamics, impulse-dynamics and simulate: the robot's feet (a list to "
        "pass as `contacts` as is); empty when not known (uploads, robots without feet).",
    )
    joints: list[JointInfo]
    frames: list[FrameInfo] = Field(
        description="Every frame of the model in model order "
        "(links, joints, fixed frames): the valid names for "
        "`frame` in jacobian, operational-space and external_forces."
    )
    reduced_from: ReducedFrom | None = Field(None, description="Present for a reduced model.")
    parent: str | None = Field(
        None,
        description="For a variant (and a reduced model): the id of the robot it derives from.",
    )
    modifications: dict[str, Any] | None = Field(
        None,
        description="For a variant: what was changed, as requested: `payloads` (with "
        "their defaults, in canonical order) and/or `locked_joints`.",
    )
    friction: list[JointFriction] | None = Field(
        None,
        description="Present for a robot stored by identification: its joints' friction "
        '(inverse-dynamics adds it with "friction": true).',
    )
