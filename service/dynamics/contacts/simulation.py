"""Simulation with a fixed contact set: the acceleration, torques and drift of `simulate`'s
rollouts when the request gives `contacts` (`service.dynamics.simulation` integrates).

At every evaluation the acceleration is constrained forward dynamics (Pinocchio's
`constraintDynamics`, see `quantities.py`) with each contact anchored where its
frame was at the initial state (`joint2_placement`: the frame's world placement at q₀). The
integrator lets the contacts drift (the constraint holds on accelerations, not positions), so
the constraint is stabilised after Baumgarte (1972): the contact acceleration is asked to be

    Jc a + γ = −Kd ė − Kp e,     Kp = ω², Kd = 2 ω,  ω = BAUMGARTE_RATE / dt,

with e the contact's placement error from its anchor (position for a point contact, position
and orientation for a 6d one) and ė its velocity: a critically damped return of the error to
zero with a time constant of dt / BAUMGARTE_RATE = 10 steps, fast enough to keep the drift at
the integrator's per-step error, slow enough to stay stable for both integrators. The drift is
reported at each sample as the largest distance of a contact frame's origin from its anchor.

A PD controller acts on the actuated joints only (its root rows are zeroed: a floating base,
free-flyer or MJCF free joint, has no motor), and its gravity compensation is
contact-consistent: the τ that contact-inverse-dynamics answers at (q, v = 0, a = 0) (the same
solve, `contacts.solve.root_balance`), so the PD target, if the contacts can hold it, is an
equilibrium.

With damping μ > 0 every evaluation iterates until the constraint violation is at most
ROLLOUT_ACCURACY = 1e-6 times (1 + ‖r‖∞) (`service.dynamics.contacts.solve`; r the desired
contact acceleration with its Baumgarte terms), or is refused. That is looser than the 1e-9 of
the contact endpoints because a nearly rank-deficient set (four point feet on legs without
abduction joints) converges slowly along its nearly singular directions, and in a rollout such
a violation is far below what Baumgarte's correction removes at every step: the drift that
matters is reported by `constraint_drift`. A rollout whose numbers overflow (a
non-finite state, torque or factorization after the first evaluation: a huge dt or gain) is
reported as diverged by the integrator (`non_finite_result`), not as a singular contact set.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from service.dynamics.contacts.model import ContactSet, constraint_models, constraint_rows
from service.dynamics.contacts.solve import (
    ROLLOUT_ACCURACY,
    check_damping,
    evaluation_work,
    forward_violation,
    not_converged,
    proximal_settings,
    root_balance,
)
from service.registry.robot import Robot

BAUMGARTE_RATE = 0.1  # ω dt: the error's time constant is 10 steps


class ContactRollout:
    """The contact side of one trajectory: build it at the initial q, then call
    `acceleration` (with the rollout's `data`) and `drift`."""

    def __init__(
        self, robot: Robot, contacts: Sequence[Mapping[str, Any]], dt: float, damping: float
    ) -> None:
        self.robot = robot
        self.damping = check_damping(damping)
        self.set: ContactSet = constraint_models(robot, contacts)
        self.settings = proximal_settings(self.damping)
        self.rate = BAUMGARTE_RATE / dt
        self.frames = self.set.frames  # `frame_id`'s rule, as every other route
        self.root = robot.root_nv
        self.anchors: list[np.ndarray] = []
        self.models: Any = None
        self.datas: Any = None
        self.state: int | None = None
        self.evaluations = 0

    def start(self, data: Any, q0: np.ndarray, state: int | None) -> None:
        """Anchor the contacts at the frames' world placements at q₀ (copies of the cached
        constraint models, with the Baumgarte gains) and prepare `data`."""
        model = self.robot.model
        pin.framesForwardKinematics(model, data, q0)
        self.models = pin.StdVec_RigidConstraintModel()
        self.datas = pin.StdVec_RigidConstraintData()
        self.anchors = []
        for cached, fid in zip(self.set.models, self.frames, strict=True):
            placement = data.oMf[fid].copy()
            self.anchors.append(np.array(placement.translation))
            cm = pin.RigidConstraintModel(
                cached.type,
                model,
                cached.joint1_id,
                cached.joint1_placement,
                0,
                placement,
                pin.ReferenceFrame.LOCAL_WORLD_ALIGNED,
            )
            gains = cm.m_baumgarte_parameters
            gains.Kp, gains.Kd = self.rate * self.rate, 2.0 * self.rate
            cm.m_baumgarte_parameters = gains
            self.models.append(cm)
            self.datas.append(cm.createData())
        pin.initConstraintDynamics(model, data, self.models, self.datas)
        self.state = state
        self.evaluations = 0

    def acceleration(
        self, robot: Robot, q: np.ndarray, v: np.ndarray, tau: np.ndarray, data: Any
    ) -> np.ndarray:
        """The constrained acceleration a (nv) at (q, v) under τ; NaN when the numbers have
        overflowed after the first evaluation (the integrator then reports divergence)."""
        first = self.evaluations == 0
        self.evaluations += 1
        if not first and not (
            np.isfinite(q).all() and np.isfinite(v).all() and np.isfinite(tau).all()
        ):
            return np.full(self.robot.nv, np.nan)
        a = np.asarray(
            pin.constraintDynamics(
                self.robot.model, data, q, v, tau, self.models, self.datas, self.settings
            )
        )
        if not first and not np.isfinite(self.set.pivots(data)).all():
            return np.full(self.robot.nv, np.nan)
        self.set.check(self.robot, data, self.state, self.damping)
        if self.damping:
            violation, accepted = forward_violation(data, self.settings, ROLLOUT_ACCURACY)
            if not violation <= accepted and np.isfinite(a).all():
                raise not_converged(
                    "forces", violation, accepted, self.damping, self.state, self.set.names
                )
        return a

    def gravity_compensation(self, q: np.ndarray, data: Any) -> np.ndarray:
        """Contact-consistent gravity compensation τ(q) (zero root rows): g(q) − Jcᵀ λ with
        λ the minimum-norm contact forces holding the root still (`root_balance`, the solve
        of contact-inverse-dynamics)."""
        g = np.array(pin.computeGeneralizedGravity(self.robot.model, data, q))
        if self.root == 0:
            return g
        Jc = self.set.frame_jacobian(self.robot, data, q)
        if not (np.isfinite(g).all() and np.isfinite(Jc).all()):
            return np.full(self.robot.nv, np.nan)  # overflowed: the integrator reports it
        return root_balance(g, Jc, self.root)[0]

    def actuated(self, tau: np.ndarray) -> np.ndarray:
        """τ with the floating root's rows zeroed."""
        if self.root:
            tau = np.array(tau, dtype=np.float64)
            tau[: self.root] = 0.0
        return tau

    def drift(self, qs: np.ndarray, data: Any) -> np.ndarray:
        """(samples,) the largest distance (m) of a contact frame's origin from its anchor."""
        model = self.robot.model
        out = np.empty(qs.shape[0])
        for k, q in enumerate(qs):
            pin.framesForwardKinematics(model, data, q)
            out[k] = max(
                float(np.linalg.norm(data.oMf[fid].translation - anchor))
                for fid, anchor in zip(self.frames, self.anchors, strict=True)
            )
        return out


ROLLOUT_OVERHEAD = 100.0  # work units (≈ 30 µs) of Python per rollout evaluation
COMPENSATION_OVERHEAD = 150.0  # and of the compensation's least squares (measured)


def rollout_evaluation_work(
    robot: Robot, contacts: Sequence[Mapping[str, Any]], damping: float, controller: bool
) -> float:
    """The work of one evaluation of a rollout with contacts (`solve`'s units): the
    constrained dynamics and the integrator's Python around it and, with a controller, the
    contact-consistent gravity compensation (an RNEA, the contacts' Jacobians and the root
    least squares). Measured within 0.26–0.37 µs a unit on Solo-12 and Talos."""
    m = constraint_rows(contacts)
    work = evaluation_work(robot.nv, m, damping) + ROLLOUT_OVERHEAD
    if controller:
        work += robot.nv + m * robot.nv / 8.0 + COMPENSATION_OVERHEAD
    return work


def pd_with_contacts(
    rollout: ContactRollout, pd: Callable[..., np.ndarray], compensate: bool
) -> Callable[[int, np.ndarray, np.ndarray, Any], np.ndarray]:
    """The PD torque source with contacts: actuated rows only, contact-consistent gravity
    compensation."""

    def torque(k: int, q: np.ndarray, v: np.ndarray, data: Any) -> np.ndarray:
        out = rollout.actuated(pd(k, q, v, data))
        if compensate:
            out = out + rollout.gravity_compensation(q, data)
        return out

    return torque
