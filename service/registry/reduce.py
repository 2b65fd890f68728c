"""Reduced models: a robot with some joints locked at given positions (Pinocchio's
`buildReducedModel`).

Locking joint j at q_j removes its entries from q (nq_j) and from v, a, τ (nv_j); the bodies it
carried are welded to its parent at the placement q_j gives. For the remaining joints, the reduced
model's M(q_r) is the block of the full M(q) on their velocity entries, where q holds q_r and the
locked values; likewise g, C and the inverse and forward dynamics with the locked joints at rest.

Value of a locked joint, by joint type (GET /v1/robots/{id} gives each joint's type):

    revolute, prismatic     a number (rad or m), or a list of one number
    continuous              an angle θ in rad, or [cos θ, sin θ] (unit norm within 1e-6)
    free_flyer              [x, y, z, qx, qy, qz, qw] (m; unit quaternion, scalar last)
    planar                  [x, y, θ] or [x, y, cos θ, sin θ]
    spherical               [qx, qy, qz, qw]; [qw, qx, qy, qz] (MuJoCo's qpos) for a model
                            built from MJCF, as its q
    any other               its nq entries of q

Unit quaternions and (cos, sin) pairs are normalized once checked. A revolute or prismatic value
outside the joint's finite position limits is rejected (422
`invalid_configuration`); free-flyer, planar, spherical and continuous joints have no limits
checked. The armature of the remaining joints, gravity, frames and limits carry over (Pinocchio);
reference configurations and the default configuration are restricted to the remaining joints.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from service.errors import InvalidConfiguration, InvalidInput, InvalidModel, did_you_mean
from service.registry.robot import Robot

UNIT_NORM_TOL = 1e-6  # as for q in dynamics requests (service.states)
LIMIT_TOL = 1e-9  # rad or m beyond a position limit still accepted (rounding)
CHECKED_LIMITS = ("revolute", "prismatic")

LockedValue = float | Sequence[float]


def _shown(name: str) -> str:
    clean = "".join(c if c.isprintable() else "?" for c in name)
    return clean if len(clean) <= 64 else clean[:64] + "…"


def as_lists(locked: Mapping[str, LockedValue]) -> dict[str, list[float]]:
    """The locked joints as requested, each value a list of floats (for ids and records)."""
    return {
        name: [float(value)] if isinstance(value, int | float) else [float(x) for x in value]
        for name, value in locked.items()
    }


def _unit(values: list[float], joint: str, kind: str) -> list[float]:
    norm = math.sqrt(sum(x * x for x in values))
    if abs(norm - 1.0) > UNIT_NORM_TOL:
        raise InvalidConfiguration(
            f"locked joint '{_shown(joint)}': the {kind} must have unit "
            f"norm; its norm is {norm:.9g}"
        )
    return [x / norm for x in values]


def _joint_q(
    joint: str, kind: str, nq: int, values: list[float], wxyz: bool = False
) -> list[float]:
    """The q entries of one locked joint from its requested value (see the module docstring),
    in Pinocchio's order; `wxyz`: a spherical joint's value is (qw, qx, qy, qz)."""
    n = len(values)
    if kind == "spherical" and n == 4 and wxyz:
        x, y, z, w = _unit(values[1:] + values[:1], joint, "quaternion (qw, qx, qy, qz)")
        return [x, y, z, w]
    if kind == "continuous" and n == 1:
        return [math.cos(values[0]), math.sin(values[0])]
    if kind == "continuous" and n == 2:
        return _unit(values, joint, "(cos θ, sin θ) pair")
    if kind == "planar" and n == 3:
        return [values[0], values[1], math.cos(values[2]), math.sin(values[2])]
    if kind == "planar" and n == 4:
        return values[:2] + _unit(values[2:], joint, "(cos θ, sin θ) pair")
    if kind == "free_flyer" and n == 7:
        return values[:3] + _unit(values[3:], joint, "quaternion (qx, qy, qz, qw)")
    if kind == "spherical" and n == 4:
        return _unit(values, joint, "quaternion (qx, qy, qz, qw)")
    if kind not in ("continuous", "planar", "free_flyer", "spherical") and n == nq:
        return values
    expected = {
        "continuous": "an angle θ or [cos θ, sin θ]",
        "planar": "[x, y, θ] or [x, y, cos θ, sin θ]",
        "free_flyer": "[x, y, z, qx, qy, qz, qw]",
        "spherical": "[qw, qx, qy, qz]" if wxyz else "[qx, qy, qz, qw]",
    }.get(kind, "a number" if nq == 1 else f"a list of its {nq} entries of q")
    raise InvalidInput(
        f"locked joint '{_shown(joint)}' is {kind}: its value must be {expected}; "
        f"{n} numbers were given"
    )


def locked_configuration(robot: Robot, locked: Mapping[str, LockedValue]) -> dict[str, list[float]]:
    """Check the locked joints of `robot` and give each one's q entries (model order).

    Raises `InvalidInput` (unknown joint names, all listed; a value of the wrong size),
    `InvalidConfiguration` (a non-unit quaternion or pair, a value outside its position limits)
    and `InvalidModel` (every moving joint locked: nothing would be left to move).
    """
    model = robot.model
    if not locked:
        raise InvalidInput("locked_joints is empty; name at least one joint to lock")
    unknown = [name for name in locked if name not in robot.joint_types]
    if unknown:
        shown = ", ".join(
            f"'{_shown(n)}'{did_you_mean(n, robot.joint_types)}" for n in unknown[:10]
        )
        more = f" and {len(unknown) - 10} more" if len(unknown) > 10 else ""
        raise InvalidInput(
            f"robot '{robot.id}' has no joint {shown}{more}; the `joints` of "
            f"GET /v1/robots/{robot.id} list the valid names"
        )
    out: dict[str, list[float]] = {}
    for jid in range(1, model.njoints):
        name = model.names[jid]
        if name not in locked:
            continue
        jm, kind = model.joints[jid], robot.joint_types[name]
        values = as_lists({name: locked[name]})[name]
        if not all(math.isfinite(x) for x in values):
            raise InvalidInput(f"locked joint '{_shown(name)}': values must be finite")
        wxyz = jm.idx_q in robot.wxyz_starts  # MuJoCo's order: w first (`Robot.mujoco_qpos`)
        q = _joint_q(name, kind, jm.nq, values, wxyz)
        if kind in CHECKED_LIMITS:
            lower = model.lowerPositionLimit[jm.idx_q : jm.idx_q + jm.nq]
            upper = model.upperPositionLimit[jm.idx_q : jm.idx_q + jm.nq]
            for x, lo, hi in zip(q, lower, upper, strict=True):
                if not lo - LIMIT_TOL <= x <= hi + LIMIT_TOL:
                    raise InvalidConfiguration(
                        f"locked joint '{_shown(name)}': {x:.9g} is outside its position "
                        f"limits [{lo:.9g}, {hi:.9g}] (rad or m)"
                    )
        out[name] = q
    if sum(model.joints[model.getJointId(n)].nv for n in out) == model.nv:
        raise InvalidModel(
            "locking every moving joint leaves nothing to move; keep at least one joint free"
        )
    return out


def _restriction(base: Any, reduced: Any) -> np.ndarray:
    """Indices into the base's q of the reduced model's q entries (joints matched by name)."""
    index: list[int] = []
    for jid in range(1, reduced.njoints):
        jm = base.joints[base.getJointId(reduced.names[jid])]
        index.extend(range(jm.idx_q, jm.idx_q + jm.nq))
    return np.array(index, dtype=int)


_ALIAS = "\x00"  # never in a name a description can give (XML cannot carry it)


def build_reduced_model(model: Any, joint_ids: list[int], q_ref: np.ndarray) -> Any:
    """`pin.buildReducedModel`, also for models where a link and a joint share a name.

    Pinocchio's reduction looks frames up by name alone and fails when two frames have the
    name (a URDF link and joint of the same name, common in the catalog: anymal_c, b1_z1, …).
    The reduction is made on a copy whose non-joint frames of shared names carry a unique
    suffix, and the names are restored on the result, in the same order."""
    counts = Counter(frame.name for frame in model.frames)
    if all(count == 1 for count in counts.values()):
        return pin.buildReducedModel(model, joint_ids, q_ref)
    renamed = pin.Model(model)
    for fid, frame in enumerate(model.frames):
        if counts[frame.name] > 1 and frame.type != pin.FrameType.JOINT:
            _rename_frame(renamed, fid, f"{frame.name}{_ALIAS}{fid}")
    reduced = pin.buildReducedModel(renamed, joint_ids, q_ref)
    for fid, frame in enumerate(reduced.frames):
        if _ALIAS in frame.name:
            _rename_frame(reduced, fid, frame.name.split(_ALIAS, 1)[0])
    return reduced


def _rename_frame(model: Any, fid: int, name: str) -> None:
    frame = model.frames[fid]
    frame.name = name
    model.frames[fid] = frame


def reduced_robot(
    base: Robot,
    locked_q: Mapping[str, list[float]],
    robot_id: str,
    name: str,
    origin: dict[str, Any],
    parent: str | None = None,
    modifications: dict[str, Any] | None = None,
) -> Robot:
    """The `Robot` of `base` with the joints of `locked_q` (from `locked_configuration`) locked.

    The base's root joint stays the reduced model's root unless it is locked ("fixed" then).
    `parent` and `modifications`: what its RobotInfo says it derives from (a variant).
    """
    model = base.model
    q_ref = (
        base.default_configuration if base.default_configuration is not None else pin.neutral(model)
    ).copy()
    ids = []
    for joint, values in locked_q.items():
        jid = model.getJointId(joint)
        q_ref[model.joints[jid].idx_q : model.joints[jid].idx_q + len(values)] = values
        ids.append(jid)
    reduced = build_reduced_model(model, sorted(ids), q_ref)
    keep = _restriction(model, reduced)
    root_locked = model.njoints > 1 and model.names[1] in locked_q
    default = None if base.default_configuration is None else base.default_configuration[keep]
    return Robot(
        id=robot_id,
        name=name,
        source="upload",
        root_joint="fixed" if root_locked else base.root_joint,
        model=reduced,
        reference_configurations={k: v[keep] for k, v in base.reference_configurations.items()},
        default_configuration=default,
        warnings=list(base.warnings),
        origin=origin,
        mujoco_qpos=base.mujoco_qpos,
        parent=parent,
        modifications=modifications,
    )
