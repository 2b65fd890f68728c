"""The numbers of a Pinocchio model the equations are derived from, as exact decimals.

Every float of the model (joint placements, axes, masses, centres of mass, inertias, armature,
gravity) becomes the `Decimal` of its shortest round-trip decimal (`repr`, at most 17
significant digits): 0.7 is 0.7, not the nearest binary fraction. The derivation then runs in
decimal arithmetic on the model's own numbers (`series.PRECISION` significant digits), and the
expressions evaluate to what Pinocchio computes in double precision from the same numbers. One
exception: rotation-matrix entries and axis components of magnitude ≤ `RESIDUE` = 1e-15 are rounding
residues of the double-precision rotation (an rpy of π/2 gives cos = 6.1e-17) and are taken as 0,
so right angles stay right angles.

Scope: a fixed base (no free-flyer or planar root joint) and at most `MAX_JOINTS` moving joints,
each revolute (bounded, one number in q) or prismatic. Anything else raises `UnsupportedModel`
saying which joint is at fault.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from decimal import Decimal
from typing import Any

from service.errors import UnsupportedModel
from service.registry.robot import joint_type

MAX_JOINTS = 6
RESIDUE = 1e-15  # rotation entries and axis components this small are rounding residues

Vec3 = tuple[Decimal, Decimal, Decimal]
Mat3 = tuple[Vec3, Vec3, Vec3]

_AXES: dict[str, Vec3] = {
    "X": (Decimal(1), Decimal(0), Decimal(0)),
    "Y": (Decimal(0), Decimal(1), Decimal(0)),
    "Z": (Decimal(0), Decimal(0), Decimal(1)),
}


def exact(x: float) -> Decimal:
    """The model number x as the exact value of its shortest round-trip decimal."""
    x = float(x)
    if not math.isfinite(x):
        raise UnsupportedModel("the model has a non-finite number; the equations need finite ones")
    return Decimal(repr(x))


def direction(x: float) -> Decimal:
    """An entry of a rotation matrix or a unit axis, exact, with rounding residues taken as 0:
    |x| ≤ `RESIDUE` (cos π/2 is 6.1e-17 in double precision, not 0; a real misalignment that
    small is below what a double-precision rotation can hold)."""
    return Decimal(0) if abs(float(x)) <= RESIDUE else exact(x)


def _vec(values: Any, entry: Any = exact) -> Vec3:
    a, b, c = (entry(v) for v in values)
    return (a, b, c)


def _mat(values: Any, entry: Any = exact) -> Mat3:
    rows = [_vec(values[r], entry) for r in range(3)]
    return (rows[0], rows[1], rows[2])


@dataclass(frozen=True)
class Joint:
    """One moving joint and the body it carries, all in exact decimals.

    `kind` is "revolute" or "prismatic"; `axis` its unit axis in its own frame; `parent` the
    index (from 0) of the parent joint, −1 for the world; the joint frame sits at
    (`rotation`, `translation`) in the parent joint's frame (m) when q = 0. The body: `mass`
    (kg), `lever` its centre of mass (m) and `inertia` its rotational inertia about the centre
    of mass (kg·m²), both in the joint frame; `armature` (kg·m² or kg) is added to M's diagonal.
    """

    name: str
    kind: str
    axis: Vec3
    parent: int
    rotation: Mat3
    translation: Vec3
    mass: Decimal
    lever: Vec3
    inertia: Mat3
    armature: Decimal


def _axis(joint_model: Any) -> Vec3:
    short = joint_model.shortname()
    if short[-1] in _AXES and short[:-1] in ("JointModelR", "JointModelP"):
        return _AXES[short[-1]]
    return _vec(joint_model.extract().axis, direction)


def moving_joints(model: Any) -> list[Joint]:
    """The model's moving joints in model order (the order of q and v), with their bodies.

    Raises `UnsupportedModel` for a free-flyer or planar root, a joint that is not a 1-DoF
    revolute or prismatic joint (continuous, spherical, mimic, …), more than `MAX_JOINTS`
    moving joints, or none."""
    joints: list[Joint] = []
    for jid in range(1, model.njoints):
        jm = model.joints[jid]
        name = model.names[jid]
        kind = joint_type(jm)
        if kind in ("free_flyer", "planar") and model.parents[jid] == 0:
            raise UnsupportedModel(
                f"the robot has a {kind.replace('_', '-')} root joint ('{name}'); the "
                "equations in explicit form are derived for fixed-base robots only"
            )
        if kind == "continuous":
            raise UnsupportedModel(
                f"joint '{name}' is continuous (two numbers in q: cos and sin of its angle); "
                "the equations in explicit form need revolute or prismatic joints with one "
                "number each"
            )
        if kind not in ("revolute", "prismatic") or jm.nq != 1 or jm.nv != 1:
            raise UnsupportedModel(
                f"joint '{name}' is of type {kind} ({jm.nv} degrees of freedom); the equations "
                "in explicit form need revolute or prismatic joints with one degree of freedom"
            )
        placement = model.jointPlacements[jid]
        body = model.inertias[jid]
        joints.append(
            Joint(
                name=name,
                kind=kind,
                axis=_axis(jm),
                parent=int(model.parents[jid]) - 1,
                rotation=_mat(placement.rotation, direction),
                translation=_vec(placement.translation),
                mass=exact(body.mass),
                lever=_vec(body.lever),
                inertia=_mat(body.inertia),
                armature=exact(model.armature[jm.idx_v]),
            )
        )
    if not joints:
        raise UnsupportedModel("the robot has no moving joint: there are no equations of motion")
    if len(joints) > MAX_JOINTS:
        raise UnsupportedModel(
            f"the robot has {len(joints)} moving joints; the equations in explicit form are "
            f"derived for at most {MAX_JOINTS}"
        )
    return joints


def gravity(model: Any) -> Vec3:
    """The model's gravity acceleration g₀ in the world frame (m/s²), exact."""
    return _vec(model.gravity.linear)
