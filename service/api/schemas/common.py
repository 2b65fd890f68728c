"""What every schema shares: one `Number`, one strict base model, the joint-space fields.

A request model's joint-space fields (q, v, a, tau) are arrays (or objects keyed by joint
name); every other field is an option passed to the computation. `Problem` is the body of
every error answer.
"""

from __future__ import annotations

import functools
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, create_model

Number = Annotated[float, Field(allow_inf_nan=False)]
# A joint-space vector keyed by joint name (see service.api.inputs): a number or a list per joint.
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
    """The base of every request body: unknown members and type coercions are refused."""

    model_config = ConfigDict(extra="forbid", strict=True)


class QRequest(StrictRequest):
    q: JointArray = joint_field(Q_DESC)


class QVRequest(QRequest):
    v: JointArray = joint_field(V_DESC)


class QVARequest(QVRequest):
    a: JointArray = joint_field(A_DESC)


class QVTauRequest(QVRequest):
    tau: JointArray = joint_field(TAU_DESC)


class OptionalVRequest(StrictRequest):
    q: JointArray = joint_field(Q_DESC)
    v: JointArray | None = joint_field("Optional. " + V_DESC, None)


Matrix = list[list[float]] | list[list[list[float]]]
Vector = list[float] | list[list[float]]
_NamedVector = dict[str, float | list[float]]
JointVector = (list[float] | list[list[float]] | list[list[list[float]]] | _NamedVector
               | list[_NamedVector] | list[list[_NamedVector]])
"""A joint-space answer: an array, or with `"joint_names": true` objects keyed by joint name."""
BY_NAME = " With \"joint_names\": true, an object keyed by joint name (a list for a batch)."


class Problem(BaseModel):
    """RFC 9457 problem details with a stable machine-readable `code`."""

    type: str = "about:blank"
    title: str
    status: int
    detail: str
    code: str


@functools.cache
def with_common_options(model: type[BaseModel]) -> type[BaseModel]:
    """`model` with the options every computing route takes besides its own: `joint_names`,
    `fill` and `payloads` (one subclass per model, so OpenAPI names stay). An option that
    applies to every quantity alike (e.g. one that modifies the model before computing) goes
    here."""
    from service.api.schemas.payloads import Payload, payloads_field

    return create_model(  # type: ignore[call-overload, no-any-return]
        model.__name__, __base__=model, __module__=model.__module__, __doc__=model.__doc__,
        joint_names=(bool, Field(False, description="Answer joint-space vectors (τ, a, g, "
                                 "C v, h; simulate's q and v) as objects keyed by joint name: "
                                 "a number for a 1-dof joint, a list for others; a list of "
                                 "objects for a batch or trajectory. Matrices stay arrays.")),
        fill=(str | None, Field(None, max_length=256, description="For joint-space inputs "
                                "keyed by joint name: joints left out take their q from this "
                                "configuration — \"neutral\" or one of the robot's "
                                "reference_configurations — and zero v, a and τ. Without it "
                                "every joint must be named (a ROS JointState without its "
                                "gripper is then a 422 listing the missing joints).")),
        payloads=(list[Payload] | None, payloads_field()))
