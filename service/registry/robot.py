"""A loaded robot: an immutable Pinocchio model, its description for clients, and a Data pool.

The model is never mutated after loading and is shared by every computation; each concurrent
computation borrows its own `pin.Data` from the pool (one Data shared by two threads gives
silently wrong answers).
"""

from __future__ import annotations

import functools
import math
import threading
import weakref
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from service import CPUS
from service.registry import data_pool

# Pinocchio joint model short names → the joint type robodyn reports.
_JOINT_TYPES = {
    "JointModelRX": "revolute",
    "JointModelRY": "revolute",
    "JointModelRZ": "revolute",
    "JointModelRevoluteUnaligned": "revolute",
    "JointModelRUBX": "continuous",
    "JointModelRUBY": "continuous",
    "JointModelRUBZ": "continuous",
    "JointModelRevoluteUnboundedUnaligned": "continuous",
    "JointModelPX": "prismatic",
    "JointModelPY": "prismatic",
    "JointModelPZ": "prismatic",
    "JointModelPrismaticUnaligned": "prismatic",
    "JointModelFreeFlyer": "free_flyer",
    "JointModelPlanar": "planar",
    "JointModelSpherical": "spherical",
    "JointModelSphericalZYX": "spherical_zyx",
    "JointModelTranslation": "translation",
}

# Joint types whose q holds a unit quaternion (x, y, z, w) or unit complex (cos, sin), and where.
UNIT_PARTS: dict[str, tuple[int, int]] = {
    "free_flyer": (3, 7),
    "spherical": (0, 4),
    "planar": (2, 4),
    "continuous": (0, 2),
}


# Threads for Pinocchio's OpenMP batch algorithms: the cores this process may run on.
# The process's CPUs, not this thread's: libgomp may have bound the importing thread to one.
PARALLEL_THREADS = max(1, len(CPUS))


def joint_type(joint: Any) -> str:
    """The robodyn name of a Pinocchio joint's type (its short name when unknown)."""
    short = joint.shortname()
    name: str = _JOINT_TYPES.get(short, short)
    return name


def floating_root_nv(model: Any) -> int:
    """The number of unactuated root rows of v (the first ones): 6 for a free-flyer first
    joint on the world (a catalog robot's or an upload's `root_joint`), 3 for a planar one,
    6 for an MJCF free joint — served as a translation joint on the world (v: the body
    origin's linear velocity, world axes) followed by a spherical joint (v: the angular
    velocity, body axes), together 6 unactuated coordinates like a free-flyer's, related to
    its by a rotation of the linear part — and 0 for a fixed base."""
    if model.njoints < 2 or model.parents[1] != 0:
        return 0
    first = joint_type(model.joints[1])
    if first in ("free_flyer", "planar"):
        return int(model.joints[1].nv)
    if (
        first == "translation"
        and model.njoints > 2
        and model.parents[2] == 1
        and joint_type(model.joints[2]) == "spherical"
    ):
        return 6
    return 0


def _finite_or_none(values: np.ndarray) -> list[float | None]:
    # JSON has no infinity: an unbounded limit is null.
    return [float(x) if math.isfinite(x) else None for x in values]


@dataclass
class Robot:
    """One servable robot. `model` is immutable after construction."""

    id: str
    name: str
    source: str  # "catalog" or "upload"
    root_joint: str
    model: Any  # pin.Model
    # (both in Pinocchio's q order; `info()` gives them in the API's, see `api_q`)
    reference_configurations: dict[str, np.ndarray] = field(default_factory=dict)
    default_configuration: np.ndarray | None = None
    contact_frames: list[dict[str, str]] = field(default_factory=list)  # suggested contacts
    warnings: list[dict[str, str]] = field(default_factory=list)
    origin: dict[str, Any] | None = None  # a reduced model: {"robot", "locked_joints"}
    # API-shaped visual entries (GET /v1/robots/{id}/visuals); None = not computed yet
    visuals: list[dict[str, Any]] | None = None
    # asset key -> file on disk, only the files the visuals reference
    asset_paths: dict[str, Path] = field(default_factory=dict)
    # q is MuJoCo's qpos (a model built from MJCF): every spherical joint's quaternion is
    # (w, x, y, z) in the API and (x, y, z, w) in Pinocchio (`pinocchio_q`, `api_q`)
    mujoco_qpos: bool = False
    # a variant (a stored derived model): its parent's id and the modifications as requested
    parent: str | None = None
    modifications: dict[str, Any] | None = None
    # identified joint friction (a robot made by identification): "coulomb", "viscous",
    # "offset", each (nv,) in N·m or N (N·m·s/rad or N·s/m for viscous); None: no model
    friction: dict[str, np.ndarray] | None = None
    # a robot stored by identification: the covariance of its base parameters' estimates
    # (`service.registry.variants.Fitted.uncertainty`); None: not identified
    identified_uncertainty: Mapping[str, Any] | None = None
    _model_pool_lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def __post_init__(self) -> None:
        self.nq: int = int(self.model.nq)  # plain attributes: read on every request
        self.nv: int = int(self.model.nv)
        self.unit_joints: list[tuple[str, int, int]] = []  # (joint name, q start, q end)
        self.joint_types: dict[str, str] = {}
        ranged: list[tuple[str, int, float, float]] = []  # revolute joints of finite range
        for jid in range(1, self.model.njoints):
            jm = self.model.joints[jid]
            self.joint_types[self.model.names[jid]] = joint_type(jm)
            lower = float(self.model.lowerPositionLimit[jm.idx_q]) if jm.nq == 1 else 0.0
            upper = float(self.model.upperPositionLimit[jm.idx_q]) if jm.nq == 1 else 0.0
            if joint_type(jm) == "revolute" and -1e9 < lower < upper < 1e9:
                ranged.append((self.model.names[jid], jm.idx_q, lower, upper))
            part = UNIT_PARTS.get(joint_type(jm))
            if part is not None:
                self.unit_joints.append(
                    (self.model.names[jid], jm.idx_q + part[0], jm.idx_q + part[1])
                )
        # (names, q indices, lower, upper in rad): `service.states.check_configuration` refuses
        # an angle a whole turn or more outside its range (an angle given in degrees)
        self.angle_ranges: tuple[list[str], np.ndarray, np.ndarray, np.ndarray] = (
            [r[0] for r in ranged],
            np.array([r[1] for r in ranged], dtype=int),
            np.array([r[2] for r in ranged]),
            np.array([r[3] for r in ranged]),
        )
        # The mass the dynamics moves (every body a joint moves, payloads included: RobotInfo's
        # `total_mass` and `moving_mass`) and the mass of the links fixed to the world (a fixed
        # base's base link: it takes no part in the dynamics; Pinocchio keeps it in the
        # universe's inertia). Their sum is the mass of the description.
        self.total_mass = float(pin.computeTotalMass(self.model))
        self.fixed_mass = float(self.model.inertias[0].mass)
        self.root_nv: int = floating_root_nv(self.model)  # unactuated root rows of v
        # q index permutations API → Pinocchio and back; None when q needs no reordering
        self.wxyz_starts: tuple[int, ...] = (
            tuple(
                self.model.joints[self.model.getJointId(name)].idx_q
                for name, kind in self.joint_types.items()
                if kind == "spherical"
            )
            if self.mujoco_qpos
            else ()
        )
        self.q_from_api: np.ndarray | None = None
        self.q_to_api: np.ndarray | None = None
        if self.wxyz_starts:
            self.q_from_api, self.q_to_api = np.arange(self.nq), np.arange(self.nq)
            for s in self.wxyz_starts:
                self.q_from_api[s : s + 4] = (s + 1, s + 2, s + 3, s)
                self.q_to_api[s : s + 4] = (s + 3, s, s + 1, s + 2)
        # Frame name → frame index. A link and a joint (an MJCF body and its joint) may share a
        # name: the body frame of that name is meant, else the first frame of that name in
        # model order (the order of `frames` in `info()`).
        self.frame_ids: dict[str, int] = {}
        self.frame_names: tuple[str, ...] = tuple(frame.name for frame in self.model.frames)
        body = pin.FrameType.BODY
        for fid, frame in enumerate(self.model.frames):
            known = self.frame_ids.get(frame.name)
            if known is None or (frame.type == body and self.model.frames[known].type != body):
                self.frame_ids[frame.name] = fid
        self._info: dict[str, Any] | None = None
        self._pool = data_pool.Pool(data_pool.BUDGET, self.nv)
        # a robot that is gone (deleted upload) gives its idle Datas back to the budget
        weakref.finalize(self, self._pool.close)

    @functools.cached_property
    def armature(self) -> np.ndarray | None:
        """The armature of each velocity coordinate (nv,), kg·m² or kg; None when it is all
        zero."""
        armature = np.array(self.model.armature, dtype=np.float64)
        return armature if armature.any() else None

    @functools.cached_property
    def model_without_armature(self) -> Any:
        """The model with every armature zero (the model itself when it has none): the bodies
        alone, for the energies (`service.dynamics.lagrangian.mechanical_energy`)."""
        if self.armature is None:
            return self.model
        bodies = self.model.copy()
        bodies.armature = np.zeros(self.nv)
        return bodies

    def pinocchio_q(self, q: np.ndarray) -> np.ndarray:
        """Configurations q (last axis nq) as the API gives them → Pinocchio's order: for a
        MuJoCo-qpos robot each quaternion (w, x, y, z) becomes (x, y, z, w); otherwise `q`
        itself. The one conversion of every q the service takes."""
        # np.take: C-contiguous (q[..., index] is not, for Pinocchio and orjson alike)
        return q if self.q_from_api is None else np.take(q, self.q_from_api, axis=-1)

    def api_q(self, q: np.ndarray) -> np.ndarray:
        """Configurations q (last axis nq) in Pinocchio's order → the API's (the inverse of
        `pinocchio_q`). The one conversion of every q the service answers."""
        return q if self.q_to_api is None else np.take(q, self.q_to_api, axis=-1)

    def data(self) -> _BorrowedData:
        """Borrow a `pin.Data` for the duration of one computation (thread-safe):
        `with robot.data() as data: ...`. Idle Datas are kept within the process's budget
        (`service.registry.data_pool`)."""
        return _BorrowedData(self)

    @contextmanager
    def model_pool(self) -> Iterator[tuple[Any, int]]:
        """Borrow this robot's `pin.ModelPool` (one Data per OpenMP thread) and the thread
        count, for Pinocchio's parallel batch algorithms. One batch at a time per robot: a
        batch already uses every core, and a pool's Datas must not be shared. The ModelPool is
        kept for the next batch within the Data budget."""
        with self._model_pool_lock:
            pool = self._pool.model_pool
            if pool is None:
                pool = pin.ModelPool(self.model, PARALLEL_THREADS)
            try:
                yield pool, PARALLEL_THREADS
            finally:
                data_pool.BUDGET.keep_model_pool(
                    self._pool, pool, PARALLEL_THREADS * self._pool.size
                )

    def summary(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "name": self.name,
            "source": self.source,
            "nq": self.nq,
            "nv": self.nv,
            "root_joint": self.root_joint,
        }

    def info(self) -> dict[str, Any]:
        """The RobotInfo document of API.md (computed once; the model never changes)."""
        if self._info is None:
            m = self.model
            joints = []
            for jid in range(1, m.njoints):
                jm = m.joints[jid]
                qs, vs = slice(jm.idx_q, jm.idx_q + jm.nq), slice(jm.idx_v, jm.idx_v + jm.nv)
                unbounded = joint_type(jm) == "continuous"  # (cos, sin): no position limit
                joints.append(
                    {
                        "name": m.names[jid],
                        "type": joint_type(jm),
                        "parent": m.names[m.parents[jid]],
                        "idx_q": int(jm.idx_q),
                        "nq": int(jm.nq),
                        "idx_v": int(jm.idx_v),
                        "nv": int(jm.nv),
                        "lower": [None] * jm.nq
                        if unbounded
                        else _finite_or_none(m.lowerPositionLimit[qs]),
                        "upper": [None] * jm.nq
                        if unbounded
                        else _finite_or_none(m.upperPositionLimit[qs]),
                        "velocity_limit": _finite_or_none(m.velocityLimit[vs]),
                        "effort_limit": _finite_or_none(m.effortLimit[vs]),
                        "armature": [float(x) for x in m.armature[vs]],
                    }
                )
            default = self.default_configuration
            neutral = [float(x) for x in self.api_q(pin.neutral(m))]
            self._info = {
                **self.summary(),
                "gravity": [float(x) for x in m.gravity.linear],
                "total_mass": self.total_mass,
                "moving_mass": self.total_mass,
                "fixed_mass": self.fixed_mass,
                "neutral_configuration": neutral,
                "default_configuration": (
                    [float(x) for x in self.api_q(default)]
                    if default is not None
                    else list(neutral)
                ),
                "reference_configurations": {
                    k: [float(x) for x in self.api_q(v)]
                    for k, v in self.reference_configurations.items()
                },
                "warnings": list(self.warnings),
                "contact_frames": [dict(c) for c in self.contact_frames],
                "joints": joints,
                "frames": [
                    {
                        "name": f.name,
                        "type": str(f.type).rsplit(".", 1)[-1].lower(),
                        "parent_joint": m.names[f.parentJoint],
                    }
                    for f in m.frames
                ],
            }
            if self.origin is not None:
                self._info["reduced_from"] = self.origin
            if self.parent is not None:
                self._info["parent"] = self.parent
                self._info["modifications"] = self.modifications or {}
            if self.friction is not None:
                self._info["friction"] = friction_table(m, self.friction)
        return self._info


def friction_table(model: Any, friction: dict[str, np.ndarray]) -> list[dict[str, Any]]:
    """RobotInfo's `friction`: one `{"joint", "coulomb", "viscous", "offset"}` per 1-DoF
    joint (τ_f = offset + coulomb sign(v) + viscous v)."""
    rows = []
    for jid in range(1, model.njoints):
        joint = model.joints[jid]
        if joint.nv == 1:
            rows.append(
                {
                    "joint": model.names[jid],
                    **{
                        k: float(friction[k][joint.idx_v]) for k in ("coulomb", "viscous", "offset")
                    },
                }
            )
    return rows


class _BorrowedData:
    """The context manager of `Robot.data` (a class: cheaper than a generator per request)."""

    __slots__ = ("data", "robot")

    def __init__(self, robot: Robot) -> None:
        self.robot = robot
        self.data: Any = None

    def __enter__(self) -> Any:
        data = self.robot._pool.take()
        self.data = self.robot.model.createData() if data is None else data
        return self.data

    def __exit__(self, *exc: object) -> None:
        self.robot._pool.give(self.data)
