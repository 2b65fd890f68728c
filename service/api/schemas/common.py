"""What every schema shares: one `Number`, one strict base model, the joint-space fields.

A request model's joint-space fields (q, v, a, tau) are arrays (or objects keyed by joint
name); every other field is an option passed to the computation. `Problem` is the body of
every error answer.
"""

from __future__ import annotations

import functools
from typing import Annotated, Any

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    GetCoreSchemaHandler,
    create_model,
    model_validator,
)
from pydantic_core import PydanticCustomError, core_schema

Number = Annotated[float, Field(allow_inf_nan=False)]
JointName = Annotated[str, Field(max_length=256)]
# A joint-space vector keyed by joint name (see service.api.inputs): a number or a list per joint.
JointsByName = dict[JointName, Number | list[Number]]


def joint_field(desc: str, default: Any = ...) -> Any:
    return Field(
        default,
        description=desc + " A 1-D array is one state; a 2-D array [N][n] is "
        "a batch of N states, and every answer then gains a leading axis of length N. "
        "Instead of an array, an object keyed by joint name (every joint named once, "
        "or some left out with `fill`; a number or a 1-list for a 1-dof joint, the "
        "angle θ or [cos θ, sin θ] for a continuous joint's q, the joint's entries "
        "for others), or a list of such objects for a batch; or a ROS JointState "
        'as JSON ({"name": [...], "position": [...], "velocity": [...], '
        '"effort": [...]}: q takes its positions, v its velocities, τ its efforts).',
    )


Q_DESC = (
    "Configuration q, length nq: rad for revolute joints, m for prismatic ones; a "
    "free-flyer base takes [x, y, z, qx, qy, qz, qw] (m, unit quaternion, scalar last), a "
    "continuous joint [cos θ, sin θ]. For a model uploaded as MJCF, q is MuJoCo's qpos "
    "(ball and free joint quaternions w first). GET /v1/robots/{id} gives each joint's "
    "idx_q."
)
V_DESC = (
    "Velocity v, length nv: rad/s or m/s; a free-flyer base takes 6 entries first "
    "(linear then angular, in the base frame)."
)
A_DESC = "Acceleration a, length nv: rad/s² or m/s² (free-flyer: linear then angular)."
TAU_DESC = "Generalized force τ, length nv: N·m for revolute joints, N for prismatic ones."


_SEQUENCES = frozenset(("list", "dict", "set", "frozenset", "tuple"))


def fail_fast(schema: Any) -> None:
    """Mark every array and object schema inside the core `schema` fail-fast: its validation
    stops at the first wrong item, so 100,000 wrong numbers cost one error, not 100,000 (each
    union member would add its own, and building them took seconds on the event loop)."""
    todo = [schema]
    while todo:
        node = todo.pop()
        if isinstance(node, dict):
            kind = node.get("type")
            if isinstance(kind, str) and kind in _SEQUENCES:
                node["fail_fast"] = True
            todo.extend(value for key, value in node.items() if key != "metadata")
        elif isinstance(node, list):
            todo.extend(node)


class StrictRequest(BaseModel):
    """The base of every request body: unknown members and type coercions are refused, and
    every array or object member fails fast (`fail_fast`): validation stops at its first wrong
    item, so the number of errors, and their cost, is bounded whatever the body's size."""

    model_config = ConfigDict(extra="forbid", strict=True)

    @classmethod
    def __get_pydantic_core_schema__(
        cls, source: Any, handler: GetCoreSchemaHandler
    ) -> core_schema.CoreSchema:
        schema = handler(source)
        fail_fast(schema)
        return schema


MAX_UNKNOWN_MEMBERS = 20
"""Unknown members of a body validated by FastAPI's router reported one by one at most; more
are one error with their count (pydantic would build an error object for each)."""
_NAME_CHARS = 64


def shortened(name: Any, chars: int = _NAME_CHARS) -> str:
    """`name` as echoed in an error: at most `chars` characters, then "…"."""
    text = str(name)
    return text if len(text) <= chars else text[:chars] + "…"


def many_unknown_members(allowed: Any, data: Any) -> tuple[int, str] | None:
    """(how many, the first) of the members of the object `data` not among `allowed` (a
    mapping or set of names) when there are more than `MAX_UNKNOWN_MEMBERS`; else None.
    Work: constant unless there are that many (then a pass over the member names)."""
    if isinstance(data, dict) and len(data) > len(allowed) + MAX_UNKNOWN_MEMBERS:
        unknown = len(data) - len(data.keys() & set(allowed))
        if unknown > MAX_UNKNOWN_MEMBERS:
            return unknown, shortened(next(k for k in data if k not in allowed))
    return None


def _refuse_many_unknown(fields: frozenset[str], data: Any) -> Any:
    many = many_unknown_members(fields, data)
    if many is not None:
        raise PydanticCustomError(
            "too_many_unknown_members",
            "has {count} members that are not fields of this request (the first: '{first}')",
            {"count": many[0], "first": many[1]},
        )
    return data


class RoutedRequest(StrictRequest):
    """A request body validated by FastAPI's router (uploads, reductions), which turns every
    pydantic error into an object: more than `MAX_UNKNOWN_MEMBERS` unknown members are refused
    by one error with their count, before pydantic validates anything (a set intersection of
    the few field names: constant work whatever the number of members)."""

    @model_validator(mode="before")
    @classmethod
    def _many_unknown_members(cls, data: Any) -> Any:
        return _refuse_many_unknown(frozenset(cls.model_fields), data)


class JointState(StrictRequest):
    """A ROS `sensor_msgs/JointState` as JSON (what rosbridge and `json.dumps` of a message
    give): joint names with their positions (rad or m), velocities (rad/s or m/s) and efforts
    (N·m or N), one number per name; empty lists where not measured. Taken as q (`position`),
    v (`velocity`) or τ (`effort`) wherever a joint-space input may be keyed by joint name."""

    name: list[JointName] = Field(max_length=10_000, description="Joint names, each once.")
    position: list[Number] = Field([], description="One per name, rad or m (q).")
    velocity: list[Number] = Field([], description="One per name, rad/s or m/s (v).")
    effort: list[Number] = Field([], description="One per name, N·m or N (τ).")
    header: dict[str, Any] | None = Field(None, description="The message's header: ignored.")


JointArray = (
    list[Number]
    | list[list[Number]]
    | JointState
    | JointsByName
    | list[JointState]
    | list[JointsByName]
)


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
JointVector = (
    list[float]
    | list[list[float]]
    | list[list[list[float]]]
    | _NamedVector
    | list[_NamedVector]
    | list[list[_NamedVector]]
)
"""A joint-space answer: an array, or with `"joint_names": true` objects keyed by joint name."""
BY_NAME = ' With "joint_names": true, an object keyed by joint name (a list for a batch).'


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

    return create_model(
        model.__name__,
        __base__=model,
        __module__=model.__module__,
        __doc__=model.__doc__,
        joint_names=(
            bool,
            Field(
                False,
                description="Answer joint-space vectors (τ, a, g, "
                "C v, h; simulate's q and v) as objects keyed by joint name: "
                "a number for a 1-dof joint, a list for others; a list of "
                "objects for a batch or trajectory. Matrices stay arrays.",
            ),
        ),
        fill=(
            str | None,
            Field(
                None,
                max_length=256,
                description="For joint-space inputs "
                "keyed by joint name: joints left out take their q from this "
                'configuration — "neutral" or one of the robot\'s '
                "reference_configurations — and zero v, a and τ. Without it "
                "every joint must be named (a ROS JointState without its "
                "gripper is then a 422 listing the missing joints).",
            ),
        ),
        payloads=(list[Payload] | None, payloads_field()),
    )
