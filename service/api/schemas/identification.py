"""Schemas of identification: the inertial parameters, the regressor and the identify route,
with sizes and units (docs/identification.md explains the model)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, Field

from service.api.schemas.common import Matrix, Number, StrictRequest
from service.api.schemas.robots import JointFriction, RobotInfo

PI_DESC = (
    "π: 10 numbers per body in joint order, each [m, m cx, m cy, m cz, Ixx, Ixy, Iyy, "
    "Ixz, Iyz, Izz] in the joint's frame: m in kg, m c in kg·m, the inertia about the "
    "joint frame's origin (not the centre of mass) in kg·m². τ = Y(q, v, a) π + "
    "armature ∘ a."
)

Row = Annotated[list[Number], Field(max_length=4096)]


class InertialParameters(BaseModel):
    bodies: list[str] = Field(
        description="The bodies in joint order, named after their joints (RobotInfo's joints)."
    )
    layout: list[str] = Field(
        description="The names of each body's 10 numbers: m, m_cx, "
        "m_cy, m_cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz."
    )
    parameters: list[float] = Field(description=PI_DESC + " Length 10 × bodies.")


class RegressorAnswer(BaseModel):
    regressor: Matrix = Field(
        description="Y(q, v, a), nv × 10·bodies (Pinocchio's joint "
        "torque regressor, the model's gravity): Y π is RNEA's τ without "
        "the armature term. (N, nv, 10·bodies) for a batch."
    )


class PayloadFrame(StrictRequest):
    frame: str = Field(
        max_length=256,
        description="The frame that holds the payload (a frame name of RobotInfo's frames).",
    )


class IdentifyRequest(StrictRequest):
    """A logged motion of a fixed-base robot: the samples in time order."""

    t: list[Number] = Field(
        description="Sample times, s, strictly increasing; irregular sampling is fine. Length N."
    )
    q: list[Row] = Field(
        description="Joint positions, N rows of nq (the API's q: a continuous "
        "joint's [cos θ, sin θ])."
    )
    tau: list[Row] = Field(description="Measured joint torques, N rows of nv, N·m or N.")
    v: list[Row] | None = Field(
        None,
        description="Optional joint velocities, N rows of nv. "
        "Absent: from q by zero-phase low-pass filtering and "
        "differentiation.",
    )
    a: list[Row] | None = Field(
        None,
        description="Optional joint accelerations, N rows of nv. "
        "Absent: by filtering and differentiating v.",
    )
    friction: Literal["none", "viscous", "coulomb-viscous"] = Field(
        "coulomb-viscous",
        description="The friction model per joint, fitted alongside: "
        'offset + Coulomb sign(v) + viscous v, or fewer terms ("none": the offset alone).',
    )
    method: Literal["least-squares", "physically-consistent"] = Field(
        "physically-consistent",
        description='"least-squares": weighted least squares; '
        '"physically-consistent": every body\'s 4×4 pseudo-inertia positive semidefinite (a '
        "semidefinite program), regularized toward the model's own values.",
    )
    weighted: bool = Field(
        True,
        description="Weight each joint's rows by its noise level (false: ordinary least squares).",
    )
    validation_fraction: float = Field(
        0.2, gt=0, le=0.5, description="The last part of the log by time held out for validation."
    )
    filter_hz: float | None = Field(
        None,
        gt=0,
        allow_inf_nan=False,
        description="Cut-off of "
        "the zero-phase low-pass filter, Hz (default 10 Hz, or a "
        "fifth of the sample rate when lower). Filtering happens "
        "when v or a is absent or this is given.",
    )
    store: bool = Field(
        True,
        description="Store the identified robot as a variant and answer its RobotInfo in `robot`.",
    )
    payload: PayloadFrame | None = Field(
        None,
        description="Identify only a payload held at "
        "this frame; every other parameter keeps the model's "
        "value.",
    )
    include_series: bool = Field(
        False,
        description="Also answer `validation_series`: the "
        "measured and predicted torques on the validation part.",
    )


class IdentifiedBody(BaseModel):
    name: str = Field(description="The body, named after its joint.")
    mass: float = Field(description="kg")
    center_of_mass: list[float] = Field(description="m, in the joint frame.")
    inertia: list[list[float]] = Field(
        description="3×3, kg·m², about the centre of mass, in the joint frame's axes."
    )
    pseudo_inertia_min_eigenvalue: float = Field(
        description="The smallest eigenvalue of the body's pseudo-inertia [[½ tr(Ī) 1 − Ī, h], "
        "[hᵀ, m]]: ≥ 0 for a physically possible body."
    )


class BaseParametersAnswer(BaseModel):
    expressions: list[str] = Field(
        description="Each base parameter (an identifiable "
        "combination) in the full parameters, e.g. "
        '"shoulder_lift_joint.m_cz + 0.425 elbow_joint.m + ...".'
    )
    values: list[float]
    standard_deviation: list[float]


class Rmse(BaseModel):
    train: list[float] = Field(
        description="Per joint, N·m (N): the identified model on the training part."
    )
    validation: list[float] = Field(description="The identified model on the held-out part.")
    validation_before: list[float] = Field(
        description="The model's own parameters (no friction) on the held-out part."
    )


class IdentifiedPayload(BaseModel):
    frame: str
    mass: float = Field(description="kg")
    center_of_mass: list[float] = Field(description="m, in the frame.")
    inertia: list[list[float]] = Field(
        description="3×3, kg·m², about the centre of mass, in "
        "the frame's axes: usable as a `payloads` entry as is."
    )


class Samples(BaseModel):
    train: int = Field(description="Training samples kept (filter margins dropped).")
    validation: int = Field(description="Validation samples kept.")
    fit: int = Field(description="Training samples fitted (after decimation).")


class ValidationSeries(BaseModel):
    t: list[float] = Field(description="s, the kept validation samples.")
    measured: list[list[float]] = Field(
        description="Measured τ (filtered like the model when the log is), rows of nv."
    )
    predicted: list[list[float]] = Field(description="The identified model's τ.")
    before: list[list[float]] = Field(description="The model's own τ (no friction).")


class IdentificationWarning(BaseModel):
    code: Literal["unexcited_joint"] = Field(
        description="unexcited_joint: the joint's motion in the log does not determine its "
        "friction (it barely moves, or its speed stays near zero)."
    )
    joint: str
    detail: str = Field(description="What the log shows of the joint, for a user.")


class IdentifyAnswer(BaseModel):
    parameters: list[float] = Field(description="The identified " + PI_DESC)
    bodies: list[IdentifiedBody]
    friction: list[JointFriction | None] = Field(
        description="Per joint, in joint order; null for a joint named in `warnings`: its "
        "friction columns are fitted (its Coulomb switching is in the torques) but their "
        "values are not determined by the log, so they are not reported, and the stored "
        "variant adds no friction on that joint."
    )
    warnings: list[IdentificationWarning] = Field(
        default_factory=list,
        description="Every joint whose motion in the log does not determine its friction.",
    )
    base_parameters: BaseParametersAnswer
    condition_number: float | None = Field(
        description="Of the weighted regressor, its "
        "columns scaled to unit norm; null when the log "
        "leaves a base parameter undetermined."
    )
    physically_consistent: bool
    rmse: Rmse
    filter_hz: float | None = Field(
        description="The cut-off used; null when the log was used as given."
    )
    samples: Samples
    robot: RobotInfo | None = Field(
        description="The stored variant (with `store`), else null: "
        "a robot of its own (201-like: the same log gives the same "
        "id) whose RobotInfo lists `friction` and `modifications`."
    )
    not_stored: str | None = Field(
        None,
        description="With `store`, why nothing was stored "
        "(a least-squares fit that is not physically consistent, "
        "or an impossible payload); else null.",
    )
    payload: IdentifiedPayload | None = Field(
        None, description="With `payload`: the identified payload."
    )
    validation_series: ValidationSeries | None = Field(None, description="With `include_series`.")
