"""Variants: stored models derived from a robot (its parent) by modifications.

A variant is its parent with, in this order,
0. repaired link inertials (`inertias`: {"links", "from", "repairs"}, the repairs computed by
   the model check, `service.registry.link_inertias`), then
1. identified values (`Fitted`, from identification): every body's inertial parameters
   replaced, and each joint's friction (RobotInfo's `friction`; inverse dynamics adds it on
   request), then
2. `payloads` (rigid bodies held by frames, `service.registry.payloads`) added to the bodies
   that carry their frames, then
3. `locked_joints` (joint name → position, `service.registry.reduce`) locked: their entries
   leave q, v, a and τ, and the bodies they moved (with any payload they hold) are welded.

Its id is derived from the parent's id and the canonical modifications (payloads in canonical
order, numbers as float64), so the same variant gets the same id on every replica and a second
request for it finds the stored one. A variant with locked joints alone is a reduced model and
keeps the id it had as one (`reduced_id`, "r-..."); with payloads it is "v-...". Its record holds
its lineage (`service.registry.lineage`: the root and each variant between), so deleting the
parent leaves the variant working.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from service.registry.link_inertias import repaired_warnings, with_link_inertias
from service.registry.payloads import PlacedPayload, canonical, carrying, derived
from service.registry.reduce import reduced_robot
from service.registry.robot import Robot
from service.registry.store import reduced_id

FRICTION_TERMS = ("coulomb", "viscous", "offset")
UNCERTAINTY_KEY = "identified_uncertainty"  # the record's member of `Fitted.uncertainty`
FrictionRow = tuple[str, float, float, float]  # (joint, coulomb, viscous, offset)


@dataclass(frozen=True)
class Fitted:
    """Identified values a variant carries: `inertial_parameters`, 10 per body of the parent in
    joint order ([m, m cx, m cy, m cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz], joint frame, inertia about
    the joint origin), and `friction`, (joint, coulomb, viscous, offset) per joint; either may
    be None. `uncertainty` (identification's, `identification.pipeline.uncertainty`: the
    covariance of the base parameters' estimates and the map P from the parameters to them)
    is kept in the variant's record beside them, not in its id nor in its `modifications`."""

    inertial_parameters: tuple[float, ...] | None = None
    friction: tuple[FrictionRow, ...] | None = None
    uncertainty: Mapping[str, Any] | None = field(default=None, compare=False)

    def __bool__(self) -> bool:
        return self.inertial_parameters is not None or self.friction is not None

    def as_dict(self) -> dict[str, Any]:
        """The members given, as stored, hashed and shown in `modifications`."""
        out: dict[str, Any] = {}
        if self.inertial_parameters is not None:
            out["inertial_parameters"] = [_number(x) for x in self.inertial_parameters]
        if self.friction is not None:
            out["friction"] = [
                {"joint": j, **dict(zip(FRICTION_TERMS, map(_number, terms), strict=True))}
                for j, *terms in self.friction
            ]
        return out

    @classmethod
    def from_dict(cls, value: Mapping[str, Any]) -> Fitted:
        """The inverse of `as_dict` (a record's, or identification's answer), with the
        record's `identified_uncertainty`, if any."""
        pi, friction = value.get("inertial_parameters"), value.get("friction")
        return cls(
            None if pi is None else tuple(float(x) for x in pi),
            None
            if friction is None
            else tuple(
                (str(f["joint"]), float(f["coulomb"]), float(f["viscous"]), float(f["offset"]))
                for f in friction
            ),
            value.get(UNCERTAINTY_KEY),
        )

    def record(self) -> dict[str, Any]:
        """The members a variant's record stores: `as_dict` and the uncertainty, if any."""
        out = self.as_dict()
        if self.uncertainty is not None:
            out[UNCERTAINTY_KEY] = dict(self.uncertainty)
        return out


NOTHING_FITTED = Fitted()


def with_parameters(model: Any, pi: Sequence[float] | np.ndarray) -> Any:
    """A copy of `model` whose bodies carry the inertial parameters π (10 per body, joint
    order); a massless body keeps its rotational inertia and no centre of mass."""
    out = pin.Model(model)
    for j, block in enumerate(np.asarray(pi, dtype=float).reshape(-1, 10), start=1):
        if block[0] == 0.0:
            xx, xy, yy, xz, yz, zz = block[4:]
            rotational = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
            out.inertias[j] = pin.Inertia(0.0, np.zeros(3), rotational)
        else:
            out.inertias[j] = pin.Inertia.FromDynamicParameters(block)
    return out


def friction_arrays(model: Any, friction: Sequence[FrictionRow]) -> dict[str, np.ndarray]:
    """`Robot.friction` of a model: each term (nv,), from the rows of the 1-DoF joints it
    has (by name; joints without a row, or locked away, have none)."""
    out = {term: np.zeros(model.nv) for term in FRICTION_TERMS}
    rows = {joint: terms for joint, *terms in friction}
    for jid in range(1, model.njoints):
        joint = model.joints[jid]
        terms = rows.get(model.names[jid])
        if terms is not None and joint.nv == 1:
            for term, value in zip(FRICTION_TERMS, terms, strict=True):
                out[term][joint.idx_v] = value
    return out


def _number(x: float) -> float:
    return float(x) + 0.0  # -0.0 → 0.0: the same payload, the same id


def canonical_payloads(payloads: Sequence[PlacedPayload]) -> list[dict[str, Any]]:
    """The payloads as stored and hashed: canonical order, plain floats."""
    return [
        {
            "frame": p.frame,
            "mass": _number(p.mass),
            "center_of_mass": [_number(x) for x in p.center_of_mass],
            "inertia": [[_number(x) for x in row] for row in p.inertia],
        }
        for p in canonical(payloads)
    ]


def variant_id(
    parent_id: str,
    payloads: Sequence[PlacedPayload],
    locked_joints: Mapping[str, list[float]],
    fitted: Fitted | None = None,
    inertias: Mapping[str, Any] | None = None,
) -> str:
    """The id of a variant of `parent_id`: `reduced_id` for locked joints alone (as reduce
    always gave), else "v-" and a hash of the parent's id and the canonical modifications."""
    fitted = fitted or NOTHING_FITTED
    if not payloads and not fitted and not inertias:
        return reduced_id(parent_id, dict(locked_joints))
    canonical_form = json.dumps(
        {
            "format": "variant",
            "base": parent_id,
            "payloads": canonical_payloads(payloads),
            "locked_joints": {k: [_number(x) for x in v] for k, v in sorted(locked_joints.items())},
            **fitted.as_dict(),
            **({"inertias": dict(inertias)} if inertias else {}),
        },
        sort_keys=True,
        separators=(",", ":"),
        ensure_ascii=False,
    )
    return "v-" + hashlib.sha256(canonical_form.encode("utf-8")).hexdigest()[:24]


def modifications(
    payloads: Sequence[PlacedPayload],
    locked_request: Mapping[str, list[float]],
    fitted: Fitted | None = None,
    inertias: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """RobotInfo's `modifications`: the locked joints as requested and the payloads (checked:
    defaults filled in, canonical order), identified values, and the repaired inertias (the
    request's `links` and `from`, and each link's `repairs`); only the kinds given."""
    out: dict[str, Any] = (fitted or NOTHING_FITTED).as_dict()
    if inertias:
        out["inertias"] = dict(inertias)
    if payloads:
        out["payloads"] = canonical_payloads(payloads)
    if locked_request:
        out["locked_joints"] = {k: list(v) for k, v in locked_request.items()}
    return out


def variant_robot(
    parent: Robot,
    payloads: Sequence[PlacedPayload],
    locked_q: Mapping[str, list[float]],
    *,
    robot_id: str,
    name: str,
    changes: dict[str, Any],
    fitted: Fitted | None = None,
    inertia_repairs: Sequence[Mapping[str, Any]] = (),
) -> Robot:
    """The `Robot` of a variant of `parent`: link inertials repaired, identified values set,
    payloads added, then `locked_q` (checked joint positions, `locked_configuration` of the
    parent) locked. `changes` is its `modifications`. Friction (the parent's, or identified)
    follows the joints by name."""
    fitted = fitted or NOTHING_FITTED
    friction = fitted.friction if fitted.friction is not None else _rows(parent)
    if inertia_repairs:
        parent = derived(parent, with_link_inertias(parent.model, inertia_repairs))
    if fitted.inertial_parameters is not None:
        parent = derived(parent, with_parameters(parent.model, fitted.inertial_parameters))
    if not locked_q:
        robot = carrying(
            parent,
            payloads,
            robot_id=robot_id,
            name=name,
            source="upload",
            parent=parent.id,
            modifications=changes,
        )
    else:
        base = carrying(parent, payloads) if payloads else parent
        robot = reduced_robot(
            base,
            locked_q,
            robot_id,
            name,
            origin={"robot": parent.id, "locked_joints": dict(locked_q)},
            parent=parent.id,
            modifications=changes,
        )
    if friction is not None:
        robot.friction = friction_arrays(robot.model, friction)
    if fitted.uncertainty is not None and not payloads and not locked_q:
        robot.identified_uncertainty = fitted.uncertainty
    robot.warnings = repaired_warnings(robot.warnings, inertia_repairs)
    return robot


def _rows(robot: Robot) -> tuple[FrictionRow, ...] | None:
    """A robot's friction as (joint, coulomb, viscous, offset) rows, None without one."""
    friction = robot.friction
    if friction is None:
        return None
    rows: list[FrictionRow] = []
    for jid in range(1, robot.model.njoints):
        joint = robot.model.joints[jid]
        if joint.nv == 1:
            i = joint.idx_v
            rows.append(
                (
                    str(robot.model.names[jid]),
                    float(friction["coulomb"][i]),
                    float(friction["viscous"][i]),
                    float(friction["offset"][i]),
                )
            )
    return tuple(rows)
