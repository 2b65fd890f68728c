"""Request and answer schemas of `simulate`: a rollout of forward dynamics from (q, v), under
torques or a PD controller, optionally with a fixed set of rigid contacts."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from service.api.schemas.common import (
    JointArray,
    JointsByName,
    JointState,
    JointVector,
    Number,
    QVRequest,
    StrictRequest,
)
from service.api.schemas.contacts import Contact, damping_field
from service.dynamics.contacts.model import MAX_CONTACTS

Gain = Number | list[Number] | JointsByName


class PDController(StrictRequest):
    """τ = kp ⊙ difference(q, q_target) − kd ⊙ v (+ g(q) with gravity_compensation)."""

    type: Literal["pd"] = Field(description='The controller: only "pd" for now.')
    kp: Gain = Field(
        description="Proportional gain, N·m/rad or N/m: a number for every joint, "
        "nv numbers, or an object keyed by joint name."
    )
    kd: Gain = Field(
        description="Derivative gain, N·m·s/rad or N·s/m: a number, nv numbers, "
        "or an object keyed by joint name."
    )
    q_target: list[Number] | JointState | JointsByName = Field(
        description="Target configuration, length nq (unit quaternions and (cos, sin) pairs), "
        "or an object keyed by joint name. The error is the tangent vector "
        "difference(q, q_target) (nv entries): on the manifold, not q_target − q."
    )
    gravity_compensation: bool = Field(
        False, description="Add g(q) to the PD torque, so that the target is an equilibrium."
    )


class SimulateRequest(QVRequest):
    dt: float = Field(gt=0, allow_inf_nan=False, description="Time step, s.")
    steps: int = Field(
        ge=1,
        description="Number of steps; the trajectory has steps + 1 samples. "
        "States × steps at most ROBODYN_MAX_SIMULATION_STEPS (default 100000), "
        "and states × steps × nv × stages at most ROBODYN_MAX_SIMULATION_WORK "
        "(default 2e7).",
    )
    tau: JointArray | None = Field(
        None,
        description="Applied generalized forces, N·m or N (all nv entries, a free-flyer's "
        "6 included): nv numbers for a constant τ, or [steps][nv] for τ_k held during step k; "
        "objects keyed by joint name also work. Without tau and controller, τ = 0.",
    )
    controller: PDController | None = Field(None, description="A PD controller instead of tau.")
    integrator: Literal["semi-implicit-euler", "rk4"] = Field(
        "semi-implicit-euler",
        description="semi-implicit Euler (v first, then q with the new "
        "v) or classical RK4; q is always integrated on the configuration manifold.",
    )
    contacts: list[Contact] | None = Field(
        None,
        max_length=MAX_CONTACTS,
        description=(
            "Optional fixed contact set for the whole rollout (e.g. all feet on the ground): the "
            "contacts hold their frames at their initial placement, with Baumgarte stabilisation "
            "of the drift (see docs/contacts.md); a PD controller then acts on the actuated "
            "joints only (nothing on a floating root), and its gravity compensation is "
            "contact-consistent (contact-inverse-dynamics at v = a = 0). Forces are not bounded "
            "by friction: the contacts never slip or lift off. With contacts the estimated work "
            "(states × steps × stages × one constrained evaluation) is at most ROBODYN_MAX_WORK."
        ),
    )
    damping: float = damping_field()


class SimulateAnswer(BaseModel):
    t: list[float] | list[list[float]] = Field(
        description="Times, steps + 1 entries from 0, "
        "s; (N, steps + 1) for a batch of initial states."
    )
    q: JointVector = Field(
        description="Configurations, (steps + 1) × nq; (N, steps + 1, nq) for a batch."
    )
    v: JointVector = Field(
        description="Velocities, (steps + 1) × nv, rad/s or m/s; (N, steps + 1, nv) for a batch."
    )
    mechanical_energy: list[float] | list[list[float]] = Field(
        description="T + U at each sample, J: T = ½ vᵀ M v (armature included), U the "
        "potential energy of gravity; (N, steps + 1) for a batch."
    )
    constraint_drift: list[float] | list[list[float]] | None = Field(
        None,
        description=(
            "Only with contacts: at each sample, the largest distance (m) of a contact frame's "
            "origin from where it started; (N, steps + 1) for a batch."
        ),
    )
