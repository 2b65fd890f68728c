"""Simulation with a fixed contact set: the acceleration, torques and drift of `simulate`'s
rollouts when the request gives `contacts` (`service.dynamics.simulation` integrates).

At every evaluation the acceleration is constrained forward dynamics (Pinocchio's
`constraintDynamics`, see `service.dynamics.contacts`) with each contact anchored where its
frame was at the initial state (`joint2_placement`: the frame's world placement at q₀). The
integrator lets the contacts drift (the constraint holds on accelerations, not positions), so
the constraint is stabilised after Baumgarte (1972): the contact acceleration is asked to be

    Jc a + γ = −Kd ė − Kp e,     Kp = ω², Kd = 2 ω,  ω = BAUMGARTE_RATE / dt,

with e the contact's placement error from its anchor (position for a point contact, position
and orientation for a 6d one) and ė its velocity: a critically damped return of the error to
zero with a time constant of dt / BAUMGARTE_RATE = 10 steps, fast enough to keep the drift at
the integrator's per-step error, slow enough to stay stable for both integrators. The drift is
reported at each sample as the largest distance of a contact frame's origin from its anchor.

A PD controller acts on the actuated joints only (its root rows are zeroed: a floating base
has no motor), and its gravity compensation is contact-consistent: the τ that
contact-inverse-dynamics answers at (q, v = 0, a = 0), so the PD target, if the contacts can
hold it, is an equilibrium.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from service.dynamics.contacts import root_rows
from service.dynamics.contacts_model import ContactSet, ContactWorkspace, constraint_models
from service.registry.robot import Robot

BAUMGARTE_RATE = 0.1  # ω dt: the error's time constant is 10 steps


class ContactRollout:
    """The contact side of one trajectory: build it at the initial q, then call
    `acceleration` (with the rollout's `data`) and `drift`."""

    def __init__(self, robot: Robot, contacts: Sequence[Mapping[str, Any]], dt: float,
                 damping: float) -> None:
        self.robot = robot
        self.set: ContactSet = constraint_models(robot, contacts)
        self.damping = damping
        self.settings = ContactWorkspace.settings(damping)
        self.rate = BAUMGARTE_RATE / dt
        self.frames = [robot.model.getFrameId(frame) for frame, _ in self.set.key]
        self.root = root_rows(robot)
        self.anchors: list[np.ndarray] = []
        self.models: Any = None
        self.datas: Any = None
        self.state: int | None = None

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
            cm = pin.RigidConstraintModel(cached.type, model, cached.joint1_id,
                                          cached.joint1_placement, 0, placement,
                                          pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            gains = cm.m_baumgarte_parameters
            gains.Kp, gains.Kd = self.rate * self.rate, 2.0 * self.rate
            cm.m_baumgarte_parameters = gains
            self.models.append(cm)
            self.datas.append(cm.createData())
        pin.initConstraintDynamics(model, data, self.models, self.datas)
        self.state = state

    def acceleration(self, robot: Robot, q: np.ndarray, v: np.ndarray, tau: np.ndarray,
                     data: Any) -> np.ndarray:
        """The constrained acceleration a (nv) at (q, v) under τ."""
        a = pin.constraintDynamics(self.robot.model, data, q, v, tau, self.models, self.datas,
                                   self.settings)
        self.set.check(self.robot, data, self.state, self.damping)
        return np.asarray(a)

    def gravity_compensation(self, q: np.ndarray, data: Any) -> np.ndarray:
        """Contact-consistent gravity compensation τ(q) (zero root rows): g(q) − Jcᵀ λ with
        λ the minimum-norm contact forces holding the root still (see contacts.py)."""
        g = np.array(pin.computeGeneralizedGravity(self.robot.model, data, q))
        k = self.root
        if k == 0:
            return g
        pin.computeJointJacobians(self.robot.model, data, q)
        pin.updateFramePlacements(self.robot.model, data)
        Jc = np.vstack([pin.getFrameJacobian(self.robot.model, data, fid,
                                             pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[rows]
                        for fid, rows in zip(self.frames, self._kind_rows(), strict=True)])
        lam = np.linalg.lstsq(Jc[:, :k].T, g[:k], rcond=None)[0]
        tau = g - Jc.T @ lam
        tau[:k] = 0.0
        return tau

    def _kind_rows(self) -> list[slice]:
        return [slice(0, 3) if kind == "point" else slice(0, 6) for _, kind in self.set.key]

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
            out[k] = max(float(np.linalg.norm(data.oMf[fid].translation - anchor))
                         for fid, anchor in zip(self.frames, self.anchors, strict=True))
        return out


def pd_with_contacts(rollout: ContactRollout, pd: Callable[..., np.ndarray], compensate: bool
                     ) -> Callable[[int, np.ndarray, np.ndarray, Any], np.ndarray]:
    """The PD torque source with contacts: actuated rows only, contact-consistent gravity
    compensation."""
    def torque(k: int, q: np.ndarray, v: np.ndarray, data: Any) -> np.ndarray:
        out = rollout.actuated(pd(k, q, v, data))
        if compensate:
            out = out + rollout.gravity_compensation(q, data)
        return out
    return torque
