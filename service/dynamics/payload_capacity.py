"""Payload capacity: the heaviest point mass a robot can hold at a frame within its effort limits.

A point mass m (kg) at c (m, in the axes of frame F from its origin) adds m · X_F · Inertia(1, c, 0)
to the body that carries F (`service.registry.payloads`). The inverse dynamics (RNEA) is linear
in the bodies' inertias, so at any state (q, v, a) the joint torques are affine in m:

    τ(m) = τ₀ + m τ₁,   τ₀ = RNEA(q, v, a) of the robot (with the payloads it already carries),
                         τ₁ = RNEA(q, v, a) of the unit mass alone (every other inertia and the
                              armature zero): the torques per kg of payload, N·m/kg or N/kg.

τ₁ includes the motion terms (the mass's share of M a + C v), not only gravity. For each velocity
coordinate i with an effort limit Lᵢ > 0 (N·m or N), |τ₀ᵢ + m τ₁ᵢ| ≤ Lᵢ holds on an interval of m
(|·| is convex), exactly (no search):

    [(−Lᵢ − τ₀ᵢ) / τ₁ᵢ, (Lᵢ − τ₀ᵢ) / τ₁ᵢ]     if τ₁ᵢ > 0
    [(Lᵢ − τ₀ᵢ) / τ₁ᵢ, (−Lᵢ − τ₀ᵢ) / τ₁ᵢ]     if τ₁ᵢ < 0
    every m (never limits) if |τ₀ᵢ| ≤ Lᵢ, else no m    if τ₁ᵢ = 0 (|τ₁ᵢ| ≤ ε₁: below)

Its part with m ≥ 0 is [loᵢ, hiᵢ], and the masses that keep every joint within its limit are
their intersection, the interval `mass_range` = [lo, hi] = [max loᵢ, min hiᵢ] (empty when a
coordinate suits no m ≥ 0 or when lo > hi). lo > 0 where the load is what keeps a joint within
its limit (a counterweight: gravity alone over the limit, the payload pulling the other way).
The capacity is m* = hi (0 when the range is empty); `mass_per_joint` is each coordinate's own
hiᵢ (none where it never limits, 0 where no m ≥ 0 suits it). The limiting joint owns the
minimizing coordinate of hi; where the range is empty, the coordinate that suits no m ≥ 0 and
is furthest over its limit with no payload (|τ₀ᵢ| / Lᵢ largest), else (every coordinate suits
some m, but not the same) the one whose hiᵢ is smallest. τ(m*) = τ₀ + m* τ₁ are the torques at
capacity. Coordinates with no effort limit (0, or none in the model, or Pinocchio's largest
double where a description gives none) and a floating root's coordinates (a free-flyer's 6, a
planar root's 3: the wrench that holds the base, no motor's) are not limits. When nothing
limits, m* is none (the range [0, none]) and τ is τ₀.

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
    mass_range: np.ndarray  # (N, 2) kg: [lo, hi] (hi inf: no upper end); NaN rows: empty

    def limiting_joint(self, state: int) -> str | None:
        index = int(self.limiting_index[state])
        return None if index < 0 else self.joint_of_index[index]

    def common_range(self) -> list[float | None] | None:
        """The masses that keep every joint within its limit at every state, [lo, hi] (kg; hi
        None: no upper end), the intersection of the states' ranges; None when it is empty."""
        if np.isnan(self.mass_range).any():
            return None
        lo, hi = float(self.mass_range[:, 0].max()), float(self.mass_range[:, 1].min())
        return None if lo > hi else [lo, hi if np.isfinite(hi) else None]

    def minimum(self) -> dict[str, Any]:
        """The smallest capacity over the batch: {mass (kg, or None when nothing limits),
        state (the first with it), limiting_joint, mass_range (`common_range`)}."""
        common = self.common_range()
        if not np.isfinite(self.mass).any():
            return {"mass": None, "state": None, "limiting_joint": None, "mass_range": common}
        state = int(np.argmin(self.mass))
        return {
            "mass": float(self.mass[state]),
            "state": state,
            "limiting_joint": self.limiting_joint(state),
            "mass_range": common,
        }

    def ranges(self) -> list[list[float | None] | None]:
        """Each state's `mass_range` as JSON: [lo, hi] (hi None: no upper end), None: empty."""
        return [
            None if np.isnan(lo) else [float(lo), float(hi) if np.isfinite(hi) else None]
            for lo, hi in self.mass_range
        ]

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
            "mass_range": self.ranges(),
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
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(mass (N,), limiting index (N,), mass per coordinate (N, nv), τ at capacity (N, nv),
    mass range (N, 2)) from τ₀, τ₁ (N, nv), the limits L (nv; 0 = none) and the per-kg torque
    ε₁ (N,) at or under which τ₁ counts as zero, by the rule of the module docstring. A row of
    the range is [lo, hi] (hi inf: no upper end), NaN where no mass suits every joint."""
    limited = np.broadcast_to(limit > 0, tau0.shape)
    moves = np.abs(tau1) > zero[:, None]
    within = np.abs(tau0) <= limit
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        per_kg = np.where(moves, tau1, 1.0)
        ends = ((-limit - tau0) / per_kg, (limit - tau0) / per_kg)
        low = np.where(moves, np.minimum(*ends), np.where(within, -np.inf, np.inf))
        high = np.where(moves, np.maximum(*ends), np.where(within, np.inf, -np.inf))
    low = np.where(limited, np.maximum(low, 0.0), 0.0)  # m ≥ 0
    high = np.where(limited, high, np.inf)
    suits = high >= low  # some m ≥ 0 keeps this coordinate within its limit
    per = np.where(suits, high, 0.0)
    lo, hi = low.max(axis=1), per.min(axis=1)
    empty = ~suits.all(axis=1) | (lo > hi)
    mass = np.where(empty, 0.0, hi)
    index = np.where(np.isfinite(hi), per.argmin(axis=1), -1)
    unsuited = ~suits.all(axis=1)
    if unsuited.any():  # suits no m ≥ 0: over its limit with no payload; the furthest over
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(~suits, np.abs(tau0) / np.where(limited, limit, 1.0), -np.inf)
        index = np.where(unsuited, ratio.argmax(axis=1), index)
    tau = tau0 + np.where(np.isfinite(mass), mass, 0.0)[:, None] * tau1
    ranges = np.where(empty[:, None], np.nan, np.stack([lo, hi], axis=1))
    return mass, index, per, tau, ranges


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
    mass, index, per, tau, ranges = capacity_from_torques(tau0, tau1, limit, zero)
    finite("payload-capacity", tau=tau)
    return Capacity(mass, index, per, tau, velocity_owners(robot), ranges)


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
    exact (no search). Answers `mass_range` [lo, hi] kg, the masses m ≥ 0 that keep every
    joint within its limit (null when there are none; hi null: no upper end; lo > 0 for a
    counterweight); `mass` (N,) kg, hi (0 when the range is empty), null where nothing limits;
    `limiting_joint`; `mass_per_joint` (N, nv) kg, the largest mass each velocity coordinate
    alone allows (null where it never limits, 0 where no mass ≥ 0 suits it); `tau` (N, nv),
    N·m or N, the torques at that mass; for a batch `minimum`: {mass, state, limiting_joint},
    the smallest capacity and the first state that has it, and its `mass_range`, the masses
    that suit every state. `effort_limits` (nv, ≥ 0, 0 = no limit) replaces
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
        "mass_range": cap.ranges() if s.batched else cap.ranges()[0],
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
        answer_size=lambda r, o, v: 3 + 2 * r.nv,
    ),
)
