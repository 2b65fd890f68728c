"""Payload capacity: the heaviest point mass a robot can hold at a frame within its effort limits.

A point mass m (kg) at c (m, in the axes of frame F from its origin) adds m · X_F · Inertia(1, c, 0)
to the body that carries F (`service.registry.payloads`). The inverse dynamics (RNEA) is linear
in the bodies' inertias, so at any state (q, v, a) the joint torques are affine in m:

    τ(m) = τ₀ + m τ₁,   τ₀ = RNEA(q, v, a) of the robot (with the payloads it already carries),
                         τ₁ = RNEA(q, v, a) of the unit mass alone (every other inertia and the
                              armature zero): the torques per kg of payload, N·m/kg or N/kg.

τ₁ includes the motion terms (the mass's share of M a + C v), not only gravity. For each velocity
coordinate i with an effort limit Lᵢ > 0 (N·m or N), |τ₀ᵢ + m τ₁ᵢ| ≤ Lᵢ holds on an interval of m
(|·| is convex), and the largest m ≥ 0 in it is, exactly (no search):

    mᵢ = 0                         if |τ₀ᵢ| > Lᵢ (over its limit already, with no payload)
    mᵢ = (Lᵢ − τ₀ᵢ) / τ₁ᵢ           if τ₁ᵢ > 0
    mᵢ = (Lᵢ + τ₀ᵢ) / (−τ₁ᵢ)        if τ₁ᵢ < 0
    mᵢ = none (never limits)        if τ₁ᵢ = 0 (|τ₁ᵢ| ≤ ε₁: the rounding of a zero, below)

and the capacity is m* = min mᵢ over the limited coordinates, the limiting joint the one that
owns the minimizing coordinate (where several are over their limit already, the one furthest
over, |τ₀ᵢ| / Lᵢ largest), and τ(m*) = τ₀ + m* τ₁ the torques at capacity. Coordinates with no
effort limit (0, or none in the model, or Pinocchio's largest double where a description gives
none) and a floating root's coordinates (a free-flyer's 6, a planar root's 3: the wrench that
holds the base, no motor's) are not limits. When nothing limits, m* is none and τ is τ₀.

A per-kg torque that is zero in exact arithmetic (a point on a joint's axis, a weight along a
vertical axis) comes out of RNEA as rounding, and (Lᵢ − τ₀ᵢ) / rounding is a finite capacity
of 10¹⁷ kg and more. Zero is decided against the size a per-kg torque can have at that state,
which does not depend on the torques computed:

    ε₁ = ZERO_TORQUE_PER_KG · Λ · (‖g‖ + Λ Σⱼ|aⱼ| + Λ (Σⱼ|vⱼ|)²)      (N·m per kg)

with Λ = max(R, 1 m) and R the reach of the chain that carries the point: the lengths of the
joint placements from the root to the frame's joint, the frame's offset and ‖c‖ (m). The
bracket bounds the held point's acceleration (m/s²: gravity, the joints' accelerations and
the centripetal and Coriolis terms at that lever), Λ its lever about any joint of the chain.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from service.dynamics import parallel
from service.dynamics.frames import frame_id
from service.dynamics.payloads import PayloadLike, RobotCache, robot_with_payloads
from service.dynamics.quantity import Quantity, Results, finite
from service.errors import DimensionMismatch, InvalidInput, NonFiniteResult
from service.registry.payloads import derived
from service.registry.robot import Robot
from service.states import States

ZERO_TORQUE_PER_KG = 1e-10  # of the state's per-kg torque scale (module docstring): a zero
PARALLEL_FROM = 64  # states from which the batch RNEA runs on every core
_unit_robots = RobotCache(16)


@dataclass(frozen=True)
class Capacity:
    """The capacity of N states. Arrays have the batch axis first; `inf` stands for "none"
    (never limits) in `mass` and `mass_per_joint`, and -1 for no limiting coordinate."""

    mass: np.ndarray  # (N,) kg
    limiting_index: np.ndarray  # (N,) velocity coordinate, -1 when nothing limits
    mass_per_joint: np.ndarray  # (N, nv) kg
    tau: np.ndarray  # (N, nv) N·m or N, at capacity
    joint_of_index: tuple[str, ...]  # (nv,) the joint that owns each velocity coordinate

    def limiting_joint(self, state: int) -> str | None:
        index = int(self.limiting_index[state])
        return None if index < 0 else self.joint_of_index[index]

    def minimum(self) -> dict[str, Any]:
        """The smallest capacity over the batch: {mass (kg, or None when nothing limits),
        state (the first with it), limiting_joint}."""
        if not np.isfinite(self.mass).any():
            return {"mass": None, "state": None, "limiting_joint": None}
        state = int(np.argmin(self.mass))
        return {
            "mass": float(self.mass[state]),
            "state": state,
            "limiting_joint": self.limiting_joint(state),
        }

    def answer(self, batched: bool) -> dict[str, Any]:
        """The JSON answer: none as null; per state (lists) for a batch, plus `minimum`."""

        def nullable(x: np.ndarray) -> Any:
            out = x.astype(object)
            out[~np.isfinite(x)] = None
            return out.tolist()

        states = range(self.mass.shape[0])
        result: dict[str, Any] = {
            "mass": nullable(self.mass),
            "limiting_joint": [self.limiting_joint(i) for i in states],
            "mass_per_joint": nullable(self.mass_per_joint),
            "tau": self.tau.tolist(),
        }
        if not batched:
            return {name: value[0] for name, value in result.items()}
        result["minimum"] = self.minimum()
        return result


def velocity_owners(robot: Robot) -> tuple[str, ...]:
    """The joint name of each of the nv velocity coordinates."""
    model = robot.model
    owners: list[str] = []
    for jid in range(1, model.njoints):
        owners.extend([model.names[jid]] * model.joints[jid].nv)
    return tuple(owners)


def limits(robot: Robot, effort_limits: np.ndarray | None) -> np.ndarray:
    """The effort limit of each velocity coordinate (nv), 0 where none: the model's or the
    given ones (≥ 0; 0 = no limit), with a floating root's coordinates (a free-flyer's 6, a
    planar root's 3) always 0."""
    if effort_limits is None:
        out = np.array(robot.model.effortLimit, dtype=float, copy=True)
        # none: 0, or the largest double (Pinocchio's value when the description gives none)
        out[~np.isfinite(out) | (out < 0) | (out >= np.finfo(float).max)] = 0.0
    else:
        out = np.asarray(effort_limits, dtype=float).copy()
        if out.shape != (robot.nv,):
            raise DimensionMismatch(
                f"effort_limits has {out.size} entries; robot '{robot.id}' has nv = {robot.nv}"
            )
        if not np.isfinite(out).all() or (out < 0).any():
            raise InvalidInput("effort_limits must be finite and ≥ 0 (N·m or N; 0 = no limit)")
    out[: robot.root_nv] = 0.0  # a floating root's rows: the wrench holding the base
    return out


def unit_mass_robot(robot: Robot, fid: int, center_of_mass: np.ndarray) -> Robot:
    """A robot with `robot`'s kinematics whose only inertia is 1 kg at `center_of_mass` in
    frame `fid` (no armature): its RNEA is τ₁, the torques per kg held there. Cached."""
    key = (fid, tuple(float(x) for x in center_of_mass))
    return _unit_robots.get(robot, key, lambda: _unit_mass_robot(robot, fid, center_of_mass))


def _unit_mass_robot(robot: Robot, fid: int, center_of_mass: np.ndarray) -> Robot:
    model = pin.Model(robot.model)
    for jid in range(model.njoints):
        model.inertias[jid] = pin.Inertia.Zero()
    model.armature = np.zeros(model.nv)
    frame = model.frames[fid]
    model.inertias[frame.parentJoint] = frame.placement.act(
        pin.Inertia(1.0, np.asarray(center_of_mass, dtype=float), np.zeros((3, 3)))
    )
    return derived(robot, model)


def batch_rnea(robot: Robot, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
    """RNEA(q, v, a) for N states, (N, nv): on every core from PARALLEL_FROM states."""
    if q.shape[0] >= PARALLEL_FROM:
        return parallel._in_chunks(robot, pin.rneaInParallel, q, v, a)
    out = np.empty((q.shape[0], robot.nv))
    with robot.data() as data:
        for i in range(q.shape[0]):
            out[i] = pin.rnea(robot.model, data, q[i], v[i], a[i])
    return out


def chain_reach(robot: Robot, fid: int, center_of_mass: np.ndarray) -> float:
    """R (m): the lengths of the joint placements from the root to the parent joint of frame
    `fid`, plus the frame's offset in that joint and ‖center_of_mass‖."""
    model = robot.model
    frame = model.frames[fid]
    reach = float(np.linalg.norm(frame.placement.translation) + np.linalg.norm(center_of_mass))
    joint = frame.parentJoint
    while joint > 0:
        reach += float(np.linalg.norm(model.jointPlacements[joint].translation))
        joint = model.parents[joint]
    return reach


def zero_torque_per_kg(
    robot: Robot, fid: int, center_of_mass: np.ndarray, v: np.ndarray, a: np.ndarray
) -> np.ndarray:
    """ε₁ (N,), N·m per kg: per state, the size under which a per-kg torque is the rounding of
    a zero (module docstring), from the model's gravity and reach and the state's v, a
    (N, nv). NonFiniteResult where that size overflows float64."""
    lever = max(chain_reach(robot, fid, center_of_mass), 1.0)
    gravity = float(np.linalg.norm(robot.model.gravity.linear))
    with np.errstate(over="ignore", invalid="ignore"):
        acceleration = gravity + lever * (np.abs(a).sum(axis=1) + np.abs(v).sum(axis=1) ** 2)
        out = ZERO_TORQUE_PER_KG * lever * acceleration
    if not np.isfinite(out).all():
        raise NonFiniteResult(
            "payload-capacity: the size of the torques per kg overflows float64 at these "
            "states (are v, a or center_of_mass extreme?)"
        )
    return np.asarray(out)


def capacity_from_torques(
    tau0: np.ndarray, tau1: np.ndarray, limit: np.ndarray, zero: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(mass (N,), limiting index (N,), mass per coordinate (N, nv), τ at capacity (N, nv))
    from τ₀, τ₁ (N, nv), the limits L (nv; 0 = none) and the per-kg torque ε₁ (N,) at or
    under which τ₁ counts as zero, by the rule of the module docstring."""
    limited = limit > 0
    moves = np.abs(tau1) > zero[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        room = np.where(tau1 > 0, limit - tau0, limit + tau0)
        per = np.where(moves, room / np.abs(np.where(moves, tau1, 1.0)), np.inf)
    over = limited & (np.abs(tau0) > limit)
    per = np.where(over, 0.0, per)
    per = np.where(limited, per, np.inf)
    mass = per.min(axis=1)
    index = np.where(np.isfinite(mass), per.argmin(axis=1), -1)
    any_over = over.any(axis=1)
    if any_over.any():  # furthest over its limit: |τ₀ᵢ| / Lᵢ largest
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(over, np.abs(tau0) / np.where(limited, limit, 1.0), -np.inf)
        index = np.where(any_over, ratio.argmax(axis=1), index)
    tau = tau0 + np.where(np.isfinite(mass), mass, 0.0)[:, None] * tau1
    return mass, index, per, tau


def capacity(
    robot: Robot,
    q: np.ndarray,
    frame: str,
    *,
    center_of_mass: Sequence[float] | None = None,
    v: np.ndarray | None = None,
    a: np.ndarray | None = None,
    payloads: Sequence[PayloadLike] | None = None,
    effort_limits: np.ndarray | None = None,
) -> Capacity:
    """The heaviest point mass `robot` can hold at `center_of_mass` (m, in `frame`, default its
    origin) for each of N states: q (N, nq) in Pinocchio's order, v and a (N, nv; rad/s, rad/s²
    or m/s, m/s²; default zero: holding still), already carrying `payloads`, within
    `effort_limits` (nv, N·m or N; default the model's). Exact (module docstring)."""
    n = q.shape[0]
    v = np.zeros((n, robot.nv)) if v is None else v
    a = np.zeros((n, robot.nv)) if a is None else a
    com = np.zeros(3) if center_of_mass is None else np.asarray(center_of_mass, dtype=float)
    if com.shape != (3,) or not np.isfinite(com).all():
        raise InvalidInput("center_of_mass must be 3 finite numbers (m, in the frame)")
    carrier = robot_with_payloads(robot, payloads)
    fid = frame_id(carrier, frame)
    limit = limits(robot, effort_limits)
    tau0 = batch_rnea(carrier, q, v, a)
    tau1 = batch_rnea(unit_mass_robot(carrier, fid, com), q, v, a)
    finite("payload-capacity", tau=tau0, torque_per_kg=tau1)
    zero = zero_torque_per_kg(carrier, fid, com, v, a)
    mass, index, per, tau = capacity_from_torques(tau0, tau1, limit, zero)
    finite("payload-capacity", tau=tau)
    return Capacity(mass, index, per, tau, velocity_owners(robot))


def payload_capacity(
    robot: Robot,
    s: States,
    *,
    frame: str,
    center_of_mass: Sequence[float] | None = None,
    effort_limits: Any = None,
) -> Results:
    """The heaviest point mass (kg) the robot can hold at `center_of_mass` (m, in `frame`;
    default its origin) without any joint torque exceeding its effort limit, per state (q; v
    and a default zero: holding still): τ(m) = τ₀ + m τ₁ is affine in m, so the answer is
    exact (no search). Answers `mass` (N,) kg, null where nothing limits; `limiting_joint`;
    `mass_per_joint` (N, nv) kg, the largest mass each velocity coordinate alone allows (null
    where it never limits, 0 where it is over its limit already); `tau` (N, nv), N·m or N, the
    torques at that mass; for a batch `minimum`: {mass, state, limiting_joint}, the smallest
    capacity and the first state that has it. `effort_limits` (nv, ≥ 0, 0 = no limit) replaces
    the model's; a floating root's rows are never limits. Payloads already carried count in
    τ₀ (the request's `payloads`)."""
    cap = capacity(
        robot,
        s["q"],
        frame,
        center_of_mass=center_of_mass,
        v=s.arrays.get("v"),
        a=s.arrays.get("a"),
        effort_limits=None if effort_limits is None else np.asarray(effort_limits, dtype=float),
    )
    names = [cap.limiting_joint(i) for i in range(cap.mass.shape[0])]
    out: dict[str, Any] = {
        "mass": cap.mass,
        "limiting_joint": names if s.batched else names[0],
        "mass_per_joint": cap.mass_per_joint,
        "tau": cap.tau,
    }
    if s.batched:
        out["minimum"] = cap.minimum()
    return out


PAYLOAD_CAPACITY = (
    Quantity(
        "payload-capacity",
        ("q",),
        payload_capacity,
        "Payload capacity: the heaviest point mass a frame can hold within the effort "
        "limits, and the joint that limits it",
        optional=("v", "a"),
        joint_answers=("tau",),
        named_options=(("effort_limits", "nv"),),
        work=lambda r, s, o: 2 * s.count * r.nv,
        whole_batch=True,
        answer_size=lambda r, o, v: 1 + 2 * r.nv,
    ),
)
