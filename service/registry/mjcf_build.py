"""A Pinocchio model built from a model MuJoCo compiled (`mujoco.MjModel`), body by body.

MuJoCo's compiler has already applied every MJCF rule (defaults and classes, compiler options,
angles, Euler sequences, inertia from geoms and meshes, includes); what is read here is the
compiled result: `body_parentid`, `body_pos` and `body_quat` (w first) at `qpos0`, `body_ipos`,
`body_iquat`, `body_mass`, `body_inertia` (principal moments), `jnt_type`, `jnt_pos`, `jnt_axis`,
`jnt_range`, `qpos0`, `dof_armature`, sites and keyframes.

Kinematics as MuJoCo's `mj_kinematics`: each joint of a body moves it about the joint's anchor
`jnt_pos` (body frame) after the joints before it, a hinge by the angle qpos − qpos0 (qpos0 is its
`ref`), a slide by qpos − qpos0 along its axis. So a body with joints j1..jk is a chain of
Pinocchio joints: joint 1 at (parent frame → body frame at qpos0) · T(p1) · R(axis1, −ref1),
joint i at T(−p(i−1) + pi) · R(axis_i, −ref_i) from joint i−1, and the body at T(−pk) from
joint k. The joints between are massless (Pinocchio's composite joint is not used).

Coordinates: hinges and slides are one number each, exactly MuJoCo's qpos. A ball joint is a
Pinocchio spherical joint whose q holds the quaternion in Pinocchio's order (x, y, z, w) where
MuJoCo's qpos has (w, x, y, z); v is the body-frame angular velocity in both. A free joint is two
Pinocchio joints, a translation (`<name>`, q = position, v = world-frame linear velocity of the
body origin) and a spherical joint (`<name>_rotation`, quaternion x, y, z, w, body-frame angular
velocity): v is exactly MuJoCo's qvel. The API gives and takes q as MuJoCo's qpos itself: a
robot built from MJCF has `Robot.mujoco_qpos`, and the service reorders each spherical joint's
quaternion at its boundary (`service.states.configurations` in, `Robot.api_q` out).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from service.errors import InvalidModel
from service.registry.urdf_check import Finding, _inertia_findings

FREE, BALL, SLIDE, HINGE = 0, 1, 2, 3  # mujoco.mjtJoint
GRAVITY_DISABLED = 128  # mujoco.mjtDisableBit.mjDSBL_GRAVITY
_AXES: dict[tuple[float, ...], str] = {
    (1.0, 0.0, 0.0): "X",
    (0.0, 1.0, 0.0): "Y",
    (0.0, 0.0, 1.0): "Z",
}


@dataclass
class MJCFModel:
    """The Pinocchio model of a compiled MJCF and what robodyn reports about it."""

    model: Any  # pin.Model
    root_joint: str  # as served: "free-flyer" when a top body has a free joint
    findings: list[Finding] = field(default_factory=list)  # inertia plausibility
    notes: list[Finding] = field(default_factory=list)  # always warnings
    # MuJoCo qpos index → Pinocchio q index of the same number (quaternions reordered)
    q_index: list[int] = field(default_factory=list)
    body_frames: list[str] = field(default_factory=list)  # MuJoCo body → Pinocchio frame name
    visuals: list[dict[str, Any]] = field(default_factory=list)  # as GET .../visuals answers

    def report(self) -> dict[str, Any]:
        """What the registry stores and reports beside the model (plain data)."""
        return {
            "root_joint": self.root_joint,
            "findings": [f.as_dict() for f in self.findings],
            "notes": [f.as_dict() for f in self.notes],
            "visuals": self.visuals,
            "bodies": len(self.body_frames) - 1,
        }


def se3(quat_wxyz: np.ndarray, pos: np.ndarray) -> Any:
    """The placement of a MuJoCo (pos, quat w-first) pair."""
    w, x, y, z = (float(c) for c in quat_wxyz)
    return pin.SE3(pin.Quaternion(w, x, y, z).normalized().matrix(), np.asarray(pos, float))


def _shift(p: np.ndarray) -> Any:
    return pin.SE3(np.eye(3), np.asarray(p, dtype=float))


def _name(mj: Any, kind: str, index: int, fallback: str, taken: set[str]) -> str:
    name = getattr(mj, kind)(index).name or fallback
    while name in taken:
        name += "_"
    taken.add(name)
    return name


def _hinge_or_slide(kind: int, axis: np.ndarray) -> Any:
    letter = _AXES.get(tuple(float(a) for a in axis))
    if kind == HINGE:
        return (
            getattr(pin, f"JointModelR{letter}")()
            if letter
            else pin.JointModelRevoluteUnaligned(axis)
        )
    return (
        getattr(pin, f"JointModelP{letter}")() if letter else pin.JointModelPrismaticUnaligned(axis)
    )


class _Builder:
    def __init__(self, mj: Any, root_joint: str) -> None:
        self.mj, self.model = mj, pin.Model()
        self.names: set[str] = {"universe", "root_joint"}
        self.frame_names: set[str] = {"universe", "root_joint"}
        self.q_index = [0] * mj.nq
        self.body_joint = [0] * mj.nbody  # Pinocchio joint moving each body
        self.body_frame = [0] * mj.nbody  # its BODY frame's index
        self.body_offset: list[Any] = [pin.SE3.Identity()] * mj.nbody  # joint → body frame
        self.root = root_joint
        if root_joint != "fixed":
            joint = (
                pin.JointModelFreeFlyer() if root_joint == "free-flyer" else pin.JointModelPlanar()
            )
            jid = self.model.addJoint(0, joint, pin.SE3.Identity(), "root_joint")
            self.body_frame[0] = self.model.addJointFrame(jid, 0)
            self.body_joint[0] = jid

    def add_joint(
        self,
        parent: int,
        joint: Any,
        placement: Any,
        name: str,
        lower: np.ndarray,
        upper: np.ndarray,
        effort: float,
    ) -> int:
        nv = joint.nv
        jid = self.model.addJoint(
            parent, joint, placement, name, np.full(nv, effort), np.full(nv, np.inf), lower, upper
        )
        self.model.addJointFrame(jid, -1)
        return int(jid)

    def body(self, b: int) -> None:
        mj, model = self.mj, self.model
        parent = int(mj.body_parentid[b])
        jid = self.body_joint[parent]
        here = self.body_offset[parent] * se3(mj.body_quat[b], mj.body_pos[b])
        body_name = _name(mj, "body", b, f"body{b}", self.frame_names)
        first, count = int(mj.body_jntadr[b]), int(mj.body_jntnum[b])
        anchor = np.zeros(3)
        for j in range(first, first + count):
            kind, qadr = int(mj.jnt_type[j]), int(mj.jnt_qposadr[j])
            name = _name(mj, "joint", j, f"{body_name}_joint{j - first}", self.names)
            if kind == FREE:
                if parent != 0 or count != 1 or self.root != "fixed":
                    raise InvalidModel(
                        f"body '{body_name}': a free joint is served only as the "
                        "single joint of a body attached to the world"
                    )
                big = np.full(3, np.inf)  # unbounded (reported as null)
                jid = self.add_joint(
                    jid, pin.JointModelTranslation(), pin.SE3.Identity(), name, -big, big, np.inf
                )
                self.names.add(f"{name}_rotation")
                jid = self.add_joint(
                    jid,
                    pin.JointModelSpherical(),
                    pin.SE3.Identity(),
                    f"{name}_rotation",
                    -np.full(4, np.inf),
                    np.full(4, np.inf),
                    np.inf,
                )
                self._map(qadr, jid, (0, 1, 2, 6, 3, 4, 5), base=-3)
                idx_v = model.joints[jid].idx_v - 3
                dof = int(mj.jnt_dofadr[j])
                model.armature[idx_v : idx_v + 6] = mj.dof_armature[dof : dof + 6]
                here = pin.SE3.Identity()
                continue
            pos = np.asarray(mj.jnt_pos[j], dtype=float)
            placement = here * _shift(pos - anchor)
            effort = (
                float(np.max(np.abs(mj.jnt_actfrcrange[j]))) if mj.jnt_actfrclimited[j] else np.inf
            )
            if kind == BALL:
                joint = pin.JointModelSpherical()
                lower, upper = -np.full(4, np.inf), np.full(4, np.inf)
                order: tuple[int, ...] = (3, 0, 1, 2)
            else:
                axis = np.asarray(mj.jnt_axis[j], dtype=float)
                ref = float(mj.qpos0[qadr])
                joint = _hinge_or_slide(kind, axis)
                placement = placement * (
                    pin.SE3(pin.exp3(-ref * axis), np.zeros(3))
                    if kind == HINGE
                    else _shift(-ref * axis)
                )
                limited = bool(mj.jnt_limited[j])
                lower = np.array([mj.jnt_range[j][0] if limited else -np.inf])
                upper = np.array([mj.jnt_range[j][1] if limited else np.inf])
                order = (0,)
            jid = self.add_joint(jid, joint, placement, name, lower, upper, effort)
            self._map(qadr, jid, order)
            dof = int(mj.jnt_dofadr[j])
            idx_v = model.joints[jid].idx_v
            model.armature[idx_v : idx_v + joint.nv] = mj.dof_armature[dof : dof + joint.nv]
            here, anchor = pin.SE3.Identity(), pos
        offset = here * _shift(-anchor)
        inertia = pin.Inertia(
            float(mj.body_mass[b]),
            np.asarray(mj.body_ipos[b], float),
            _rotated(mj.body_iquat[b], mj.body_inertia[b]),
        )
        model.appendBodyToJoint(jid, inertia, offset)
        self.body_frame[b] = model.addBodyFrame(body_name, jid, offset, self.body_frame[parent])
        self.body_joint[b], self.body_offset[b] = jid, offset

    def _map(self, qadr: int, jid: int, order: tuple[int, ...], base: int = 0) -> None:
        idx_q = self.model.joints[jid].idx_q + base
        for k, target in enumerate(order):
            self.q_index[qadr + k] = idx_q + target

    def sites(self) -> None:
        mj = self.mj
        for s in range(mj.nsite):
            b = int(mj.site_bodyid[s])
            name = _name(mj, "site", s, f"site{s}", self.frame_names)
            placement = self.body_offset[b] * se3(mj.site_quat[s], mj.site_pos[s])
            self.model.addFrame(
                pin.Frame(
                    name, self.body_joint[b], self.body_frame[b], placement, pin.FrameType.OP_FRAME
                )
            )

    def configuration(self, qpos: np.ndarray) -> np.ndarray:
        """Pinocchio's q of a MuJoCo qpos (a root joint robodyn added is at its neutral)."""
        q: np.ndarray = pin.neutral(self.model)
        q[self.q_index] = qpos
        return q


def _rotated(iquat: np.ndarray, moments: np.ndarray) -> np.ndarray:
    R = se3(iquat, np.zeros(3)).rotation
    inertia: np.ndarray = R @ np.diag(np.asarray(moments, dtype=float)) @ R.T
    return inertia


def _notes(mj: Any) -> list[Finding]:
    notes = []
    for e in range(mj.neq):
        name = mj.equality(e).name or f"equality{e}"
        notes.append(
            Finding(
                "ignored_equality",
                "equality",
                name,
                f"equality constraint '{name}' is not part of the model: robodyn "
                "computes the dynamics of the open kinematic tree",
            )
        )
    for t in range(mj.ntendon):
        name = mj.tendon(t).name or f"tendon{t}"
        notes.append(
            Finding(
                "ignored_tendon",
                "tendon",
                name,
                f"tendon '{name}' is not part of the model: robodyn computes the "
                "rigid-body dynamics of the joints (no tendon forces or armature)",
            )
        )
    return notes


def pinocchio_model(mj: Any, root_joint: str = "fixed", gravity: Any = None) -> MJCFModel:
    """The Pinocchio model of compiled MuJoCo model `mj` (see the module docstring).

    `root_joint` "free-flyer"/"planar" adds that joint between the world and the model's bodies
    (only for a model with a single top body without joints); "fixed" adds nothing. Gravity is
    the model's `<option gravity>` (zero if its `<flag gravity="disable"/>`) unless `gravity`
    (m/s², world frame) is given.
    """
    tops = [b for b in range(1, mj.nbody) if mj.body_parentid[b] == 0]
    has_free = any(mj.jnt_type[j] == FREE for j in range(mj.njnt))
    served = "free-flyer" if has_free else root_joint
    if has_free and root_joint == "free-flyer":
        root_joint = "fixed"  # the free joint is the root
    if root_joint != "fixed" and (len(tops) != 1 or mj.body_jntnum[tops[0]]):
        raise InvalidModel(
            f"root_joint '{root_joint}' is added only above a single top body "
            "without joints; this model has "
            f"{len(tops)} top bodies{' with joints' if len(tops) == 1 else ''}"
        )
    builder = _Builder(mj, root_joint)
    findings: list[Finding] = []
    for b in range(1, mj.nbody):
        builder.body(b)
        if mj.body_jntnum[b] or builder.body_joint[b]:
            name = builder.model.frames[builder.body_frame[b]].name
            findings += _inertia_findings(name, _rotated(mj.body_iquat[b], mj.body_inertia[b]))
    builder.sites()
    model = builder.model
    if model.nv == 0:
        raise InvalidModel("the description has no joint: nothing can move")
    if gravity is None:  # the model's own, zero when its <flag gravity="disable"/>
        gravity = np.zeros(3) if mj.opt.disableflags & GRAVITY_DISABLED else mj.opt.gravity
    model.gravity = pin.Motion(np.asarray(gravity, dtype=float), np.zeros(3))
    model.referenceConfigurations["qpos0"] = builder.configuration(mj.qpos0)
    for k in range(mj.nkey):
        model.referenceConfigurations[mj.key(k).name or f"key{k}"] = builder.configuration(
            mj.key_qpos[k]
        )
    frames = ["universe"] + [model.frames[builder.body_frame[b]].name for b in range(1, mj.nbody)]
    return MJCFModel(model, served, findings, _notes(mj), builder.q_index, frames)
