"""Variants: stored models derived from a robot (its parent) by modifications.

A variant is its parent with, in this order,
1. `payloads` (rigid bodies held by frames, `service.registry.payloads`) added to the bodies
   that carry their frames, then
2. `locked_joints` (joint name → position, `service.registry.reduce`) locked: their entries
   leave q, v, a and τ, and the bodies they moved (with any payload they hold) are welded.

Its id is derived from the parent's id and the canonical modifications (payloads in canonical
order, numbers as float64), so the same variant gets the same id on every replica and a second
request for it finds the stored one. A variant with locked joints alone is a reduced model and
keeps the id it had as one (`reduced_id`, "r-..."); with payloads it is "v-...". Its record embeds
what rebuilds the parent (`Registry`), so deleting the parent leaves the variant working.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from typing import Any

from service.registry.payloads import PlacedPayload, canonical, carrying
from service.registry.reduce import reduced_robot
from service.registry.robot import Robot
from service.registry.store import reduced_id


def _number(x: float) -> float:
    return float(x) + 0.0  # -0.0 → 0.0: the same payload, the same id


def canonical_payloads(payloads: Sequence[PlacedPayload]) -> list[dict[str, Any]]:
    """The payloads as stored and hashed: canonical order, plain floats."""
    return [{"frame": p.frame, "mass": _number(p.mass),
             "center_of_mass": [_number(x) for x in p.center_of_mass],
             "inertia": [[_number(x) for x in row] for row in p.inertia]}
            for p in canonical(payloads)]


def variant_id(parent_id: str, payloads: Sequence[PlacedPayload],
               locked_joints: Mapping[str, list[float]]) -> str:
    """The id of a variant of `parent_id`: `reduced_id` for locked joints alone (as reduce
    always gave), else "v-" and a hash of the parent's id and the canonical modifications."""
    if not payloads:
        return reduced_id(parent_id, dict(locked_joints))
    canonical_form = json.dumps(
        {"format": "variant", "base": parent_id, "payloads": canonical_payloads(payloads),
         "locked_joints": {k: [_number(x) for x in v] for k, v in sorted(locked_joints.items())}},
        sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return "v-" + hashlib.sha256(canonical_form.encode("utf-8")).hexdigest()[:24]


def modifications(payloads: Sequence[PlacedPayload],
                  locked_request: Mapping[str, list[float]]) -> dict[str, Any]:
    """RobotInfo's `modifications`: the locked joints as requested and the payloads (checked:
    defaults filled in, canonical order); only the kinds given."""
    out: dict[str, Any] = {}
    if payloads:
        out["payloads"] = canonical_payloads(payloads)
    if locked_request:
        out["locked_joints"] = {k: list(v) for k, v in locked_request.items()}
    return out


def variant_robot(parent: Robot, payloads: Sequence[PlacedPayload],
                  locked_q: Mapping[str, list[float]], *, robot_id: str, name: str,
                  changes: dict[str, Any]) -> Robot:
    """The `Robot` of a variant of `parent`: payloads added, then `locked_q` (checked joint
    positions, `locked_configuration` of the parent) locked. `changes` is its `modifications`."""
    if not locked_q:
        return carrying(parent, payloads, robot_id=robot_id, name=name, source="upload",
                        parent=parent.id, modifications=changes)
    base = carrying(parent, payloads) if payloads else parent
    return reduced_robot(base, locked_q, robot_id, name,
                         origin={"robot": parent.id, "locked_joints": dict(locked_q)},
                         parent=parent.id, modifications=changes)
