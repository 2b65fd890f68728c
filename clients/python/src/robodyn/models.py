"""Typed, immutable descriptions of robots, read from the server's JSON answers.

Every class keeps the JSON object it was read from in `raw` (a read-only mapping), so fields that
a newer server adds are available before this client names them. Vectors a caller may feed back
to the dynamics (configurations, gravity) are read-only float64 numpy arrays; joint limits are
tuples with None where a limit is unbounded. Units are SI (m, rad, kg, m/s²).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np


def _frozen(raw: Mapping[str, Any]) -> Mapping[str, Any]:
    return MappingProxyType(dict(raw))


def _vector(values: Any) -> np.ndarray:
    arr = np.array(values, dtype=np.float64)
    arr.flags.writeable = False
    return arr


Limit = float | None | tuple[float | None, ...]
"""A joint's limit: one number (None: unbounded) for a 1-DoF joint, a tuple for others."""


def _limits(values: Any, one_dof: bool) -> Limit:
    """A per-joint limit: a float (None when unbounded) for a 1-DoF joint, whose position
    limits are None when it is continuous (q = (cos θ, sin θ) has no limit); else a tuple
    with None where a limit is unbounded."""
    limits = tuple(None if x is None else float(x) for x in values)
    if one_dof and len(limits) == 1:
        return limits[0]
    if one_dof and limits and all(x is None for x in limits):
        return None
    return limits


@dataclass(frozen=True)
class Finding:
    """A physical finding in a robot description (e.g. an inertia with a negative principal
    moment) or a note on an upload's assets: `code`, the `element` kind ("link", "joint" or
    "asset"), its `name`, and a `message`; `raw` has every member (a `missing_mesh`'s
    `file`)."""

    code: str
    element: str
    name: str
    message: str
    raw: Mapping[str, Any] = field(repr=False, compare=False)

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Finding:
        return cls(
            code=str(data.get("code", "")),
            element=str(data.get("element", "")),
            name=str(data.get("name", "")),
            message=str(data.get("message", "")),
            raw=_frozen(data),
        )


@dataclass(frozen=True)
class FrameInfo:
    """A frame of the model (link, joint or fixed frame) and the joint that carries it."""

    name: str
    type: str
    parent_joint: str
    raw: Mapping[str, Any] = field(repr=False, compare=False)

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> FrameInfo:
        return cls(
            name=data["name"],
            type=data.get("type", ""),
            parent_joint=data.get("parent_joint", ""),
            raw=_frozen(data),
        )


@dataclass(frozen=True)
class JointInfo:
    """One joint, in model order: where its entries sit in q (`idx_q`, `nq` entries) and in
    v, a, τ (`idx_v`, `nv` entries), and its limits.

    For a 1-DoF joint (nv = 1: revolute, prismatic, continuous) each limit is one number:
    `lower`/`upper` (rad or m; None for a continuous joint), `velocity_limit` (rad/s or m/s),
    `effort_limit` (N·m or N) and `armature` (kg·m² or kg, added to M's diagonal), e.g.
    `effort_limit == 87.0`. For other joints they are tuples: `lower`/`upper` of `nq` entries,
    the others of `nv` (a free-flyer's or a planar joint's). A limit is None when unbounded.
    """

    name: str
    type: str
    parent: str
    idx_q: int
    nq: int
    idx_v: int
    nv: int
    lower: Limit
    upper: Limit
    velocity_limit: Limit
    effort_limit: Limit
    armature: float | tuple[float, ...]
    raw: Mapping[str, Any] = field(repr=False, compare=False)

    @property
    def q_slice(self) -> slice:
        """This joint's entries of q: `q[joint.q_slice]`."""
        return slice(self.idx_q, self.idx_q + self.nq)

    @property
    def v_slice(self) -> slice:
        """This joint's entries of v, a and τ: `v[joint.v_slice]`."""
        return slice(self.idx_v, self.idx_v + self.nv)

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> JointInfo:
        one = int(data["nv"]) == 1
        armature = tuple(float(x) for x in data.get("armature", ()))
        return cls(
            name=data["name"],
            type=data["type"],
            parent=data.get("parent", ""),
            idx_q=int(data["idx_q"]),
            nq=int(data["nq"]),
            idx_v=int(data["idx_v"]),
            nv=int(data["nv"]),
            lower=_limits(data.get("lower", ()), one),
            upper=_limits(data.get("upper", ()), one),
            velocity_limit=_limits(data.get("velocity_limit", ()), one),
            effort_limit=_limits(data.get("effort_limit", ()), one),
            armature=armature[0] if one and len(armature) == 1 else armature,
            raw=_frozen(data),
        )


@dataclass(frozen=True)
class RobotSummary:
    """A robot as listed by `robots()`: `id` (what every other call takes), `name`, `source`
    ("catalog" or "upload"), `nq` (length of q) and `nv` (length of v, a, τ)."""

    id: str
    name: str
    source: str
    nq: int
    nv: int
    root_joint: str | None
    raw: Mapping[str, Any] = field(repr=False, compare=False)

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> RobotSummary:
        return cls(
            id=data["id"],
            name=data["name"],
            source=data["source"],
            nq=int(data["nq"]),
            nv=int(data["nv"]),
            root_joint=data.get("root_joint"),
            raw=_frozen(data),
        )


@dataclass(frozen=True)
class RobotList(Sequence[RobotSummary]):
    """The answer of `robots()` (every robot) and `robot_page()` (one page of the list): a
    sequence of `RobotSummary`, plus `unavailable`, the catalog robots the server could not
    load (id → reason), and `next_cursor`, where the next page starts (None after the last
    page, and for `robots()`). `"ur5" in robots` tests an id."""

    robots: tuple[RobotSummary, ...]
    unavailable: Mapping[str, str]
    raw: Mapping[str, Any] = field(repr=False, compare=False)
    next_cursor: str | None = None

    @property
    def ids(self) -> list[str]:
        return [r.id for r in self.robots]

    def __len__(self) -> int:
        return len(self.robots)

    def __getitem__(self, index: Any) -> Any:
        return self.robots[index]

    def __iter__(self) -> Iterator[RobotSummary]:
        return iter(self.robots)

    def __contains__(self, item: object) -> bool:
        return item in self.ids if isinstance(item, str) else item in self.robots

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> RobotList:
        return cls(
            robots=tuple(RobotSummary.from_json(r) for r in data["robots"]),
            unavailable=_frozen(data.get("unavailable") or {}),
            raw=_frozen(data),
            next_cursor=data.get("next_cursor"),
        )

    @classmethod
    def joined(cls, pages: Sequence[RobotList]) -> RobotList:
        """The whole list from its pages, in order (`unavailable` from the last page)."""
        robots = tuple(r for p in pages for r in p.robots)
        unavailable = pages[-1].unavailable
        raw = {"robots": [r.raw for r in robots], "unavailable": unavailable, "next_cursor": None}
        return cls(robots=robots, unavailable=unavailable, raw=_frozen(raw))


@dataclass(frozen=True, eq=False)
class RobotInfo:
    """Everything `robot(id)` (and `upload`) tells about a model.

    `nq`/`nv` are the lengths of q and of v, a, τ; `joints` says where each joint sits in them.
    `gravity` (m/s², world frame), `total_mass` (kg: the mass the dynamics moves, also
    `moving_mass`; `fixed_mass` is that of the links fixed to the world), `neutral_configuration`,
    `default_configuration` and each of `reference_configurations` (length nq) are ready to pass
    as q. `warnings` lists physical findings in the description. `created` is True or False in
    the answer of an upload (a new model, or one already stored) and None otherwise. A variant
    (and a reduced model) names its `parent` and its `modifications` (payloads, locked joints, as
    requested); other robots have None.
    Compare two infos by `id` (their arrays make `==` ambiguous, so it is identity).
    """

    id: str
    name: str
    source: str
    nq: int
    nv: int
    root_joint: str
    gravity: np.ndarray
    total_mass: float
    neutral_configuration: np.ndarray
    default_configuration: np.ndarray
    reference_configurations: Mapping[str, np.ndarray]
    warnings: tuple[Finding, ...]
    joints: tuple[JointInfo, ...]
    frames: tuple[FrameInfo, ...]
    raw: Mapping[str, Any] = field(repr=False)
    created: bool | None = None
    moving_mass: float = 0.0
    fixed_mass: float = 0.0
    parent: str | None = None
    modifications: Mapping[str, Any] | None = None

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.joints]

    @property
    def frame_names(self) -> list[str]:
        return [f.name for f in self.frames]

    @property
    def contact_frames(self) -> list[dict[str, str]]:
        """Suggested contacts (the robot's feet), ready to pass as `contacts`:
        `[{"frame": "FL_FOOT", "type": "point"}, ...]`; empty when the server knows none."""
        return [dict(c) for c in self.raw.get("contact_frames", [])]

    def joint(self, name: str) -> JointInfo:
        """The joint called `name`; KeyError (listing the names) if there is none."""
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(
            f"robot '{self.id}' has no joint '{name}'; its joints are "
            f"{', '.join(self.joint_names) or '(none)'}"
        )

    @classmethod
    def from_json(cls, data: Mapping[str, Any], created: bool | None = None) -> RobotInfo:
        neutral = _vector(data["neutral_configuration"])
        return cls(
            id=data["id"],
            name=data["name"],
            source=data["source"],
            nq=int(data["nq"]),
            nv=int(data["nv"]),
            root_joint=data.get("root_joint", ""),
            gravity=_vector(data["gravity"]),
            total_mass=float(data["total_mass"]),
            neutral_configuration=neutral,
            default_configuration=_vector(data.get("default_configuration", neutral)),
            reference_configurations=MappingProxyType(
                {k: _vector(v) for k, v in (data.get("reference_configurations") or {}).items()}
            ),
            warnings=tuple(Finding.from_json(w) for w in data.get("warnings") or ()),
            joints=tuple(JointInfo.from_json(j) for j in data["joints"]),
            frames=tuple(FrameInfo.from_json(f) for f in data.get("frames") or ()),
            raw=_frozen(data),
            created=created,
            moving_mass=float(data.get("moving_mass", data["total_mass"])),
            fixed_mass=float(data.get("fixed_mass", 0.0)),
            parent=data.get("parent"),
            modifications=(
                _frozen(data["modifications"]) if data.get("modifications") is not None else None
            ),
        )
