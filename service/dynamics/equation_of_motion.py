"""The terms of the joint-space equation of motion, M(q) a + C(q, v) v + g(q) = τ.

One function per physical quantity. Each takes a `Robot` and validated `States` (arrays of shape
(N, n), see `service.states`), borrows its own `pin.Data` for the computation, and returns arrays
with the batch axis first. Units are SI: q in rad (revolute) or m (prismatic), v in rad/s or m/s,
a in rad/s² or m/s², τ in N·m or N; M in kg·m² (or kg), g and C v in the units of τ.

A non-finite result (e.g. forward dynamics of a robot with a massless moving body) raises
`NonFiniteResult`: JSON cannot carry it, and it is never silently returned.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from service.dynamics import parallel
from service.dynamics.external_forces import ExternalForces
from service.dynamics.joint_loads import add_friction, moving_joints, rnea_with_wrenches
from service.dynamics.quantity import (
    Quantity,
    Results,
    StateByState,
    finite,
    matrix,
    nv_numbers,
    nv_squared_numbers,
)
from service.errors import InvalidInput
from service.registry.robot import Robot
from service.states import States


def mass_matrices_into(robot: Robot, s: States, out: Results) -> None:
    """M(q) of each state of `s` (CRBA) written into out["mass_matrix"][i], (nv, nv) in kg·m²
    (or kg). Includes the armature on its diagonal."""
    q, M = s["q"], out["mass_matrix"]
    with robot.data() as data:
        for i in range(q.shape[0]):
            M[i] = matrix(pin.crba(robot.model, data, q[i]), robot.nv, robot.nv)
    # The CRBA algorithm fills only the upper triangle (the C++ trap), but Pinocchio's Python
    # `crba` copies it down before returning (its binding's make_symmetric): M comes back
    # exactly symmetric, so no second pass over N·nv² numbers here (tested, batch and single).


MASS_MATRIX = StateByState(
    lambda robot: {"mass_matrix": (robot.nv, robot.nv)}, mass_matrices_into, "mass-matrix"
)


def mass_matrix(robot: Robot, s: States) -> Results:
    """M(q), the joint-space inertia matrix (CRBA), shape (N, nv, nv), symmetric positive
    definite; the kinetic energy is T = ½ vᵀ M v. Includes the armature on its diagonal."""
    return MASS_MATRIX.compute(robot, s)


def gravity(robot: Robot, s: States) -> Results:
    """g(q), the generalized gravity torques (gradient of the potential energy), (N, nv)."""
    q = s["q"]
    out = np.empty((q.shape[0], robot.nv))
    with robot.data() as data:
        for i in range(q.shape[0]):
            out[i] = pin.computeGeneralizedGravity(robot.model, data, q[i])
    return finite("gravity", gravity=out)


def coriolis_into(robot: Robot, s: States, out: Results) -> None:
    """C(q, v) of each state of `s` written into out["coriolis_matrix"][i], (nv, nv), with
    Ṁ = C + Cᵀ, and the forces C(q, v) v into out["coriolis_forces"][i], (nv,)."""
    q, v = s["q"], s["v"]
    C, Cv = out["coriolis_matrix"], out["coriolis_forces"]
    with robot.data() as data:
        for i in range(q.shape[0]):
            C[i] = matrix(
                pin.computeCoriolisMatrix(robot.model, data, q[i], v[i]), robot.nv, robot.nv
            )
    np.einsum("nij,nj->ni", C, v, out=Cv)


CORIOLIS = StateByState(
    lambda robot: {"coriolis_matrix": (robot.nv, robot.nv), "coriolis_forces": (robot.nv,)},
    coriolis_into,
    "coriolis",
)


def coriolis(robot: Robot, s: States) -> Results:
    """C(q, v), the Coriolis/centrifugal matrix with Ṁ = C + Cᵀ, (N, nv, nv), and the forces
    C(q, v) v, (N, nv)."""
    return CORIOLIS.compute(robot, s)


def nonlinear_effects(robot: Robot, s: States) -> Results:
    """h(q, v) = C(q, v) v + g(q) (Pinocchio's nonlinear effects include gravity), (N, nv).

    Computed as RNEA with a = 0 (Pinocchio's `nonLinearEffects` up to rounding), the
    algorithm `rneaInParallel` runs on large batches: a state gives the same bits either way."""
    q, v = s["q"], s["v"]
    out = np.empty((q.shape[0], robot.nv))
    zero = np.zeros(robot.nv)
    with robot.data() as data:
        for i in range(q.shape[0]):
            out[i] = pin.rnea(robot.model, data, q[i], v[i], zero)
    return finite("nonlinear-effects", nonlinear_effects=out)


def inverse_dynamics(
    robot: Robot,
    s: States,
    *,
    external_forces: Sequence[Mapping[str, Any]] | None = None,
    friction: bool = False,
    loads: bool = False,
) -> Results:
    """τ = M(q) a + C(q, v) v + g(q) by the recursive Newton–Euler algorithm, (N, nv).

    With `external_forces` (wrenches at named frames, see `service.dynamics.external_forces`)
    the answer is τ = M a + C v + g − Σ Jᵀ w: the forces the joints must add to the wrenches
    the environment applies. With `friction` (a robot made by identification, whose RobotInfo
    lists its `friction`), the joints' friction torque is added:
    τ + offset + coulomb ∘ sign(v) + viscous ∘ v. With `loads`, also `joint_wrenches`
    (N, njoints − 1, 6): the wrench each moving joint transmits to its child body, RNEA's
    `data.f[j]`, f (N) then n (N·m) about the joint frame's origin in its axes, friction
    included along the joint's motion (`service.dynamics.joint_loads`)."""
    q, v, a = s["q"], s["v"], s["a"]
    forces = ExternalForces(robot, external_forces, s) if external_forces else None
    wrenches = None
    if loads:
        out, wrenches = rnea_with_wrenches(robot, q, v, a, forces.at if forces else None)
    else:
        out = np.empty((q.shape[0], robot.nv))
        with robot.data() as data:
            if forces is None:
                for i in range(q.shape[0]):
                    out[i] = pin.rnea(robot.model, data, q[i], v[i], a[i])
            else:
                for i in range(q.shape[0]):
                    fext = forces.at(data, q[i], i)
                    out[i] = pin.rnea(robot.model, data, q[i], v[i], a[i], fext)
    if friction:
        friction_torque = joint_friction(robot)(v)
        out += friction_torque
        if wrenches is not None:
            wrenches = add_friction(robot, wrenches, friction_torque)
    if wrenches is None:
        return finite("inverse-dynamics", tau=out)
    return finite("inverse-dynamics", tau=out, joint_wrenches=wrenches)


def inverse_dynamics_size(robot: Robot, options: dict[str, Any], with_v: bool) -> int:
    """τ (nv numbers), and with `loads` the wrench of every moving joint (6 numbers each)."""
    return robot.nv + (6 * moving_joints(robot) if options.get("loads") else 0)


def joint_friction(robot: Robot) -> Callable[[np.ndarray], np.ndarray]:
    """The friction torque of the joints of a robot made by identification, as a function of
    v (..., nv) → τ_f (..., nv), N·m or N: τ_f = offset + coulomb ∘ sign(v) + viscous ∘ v.
    A robot without a friction model (its RobotInfo lists no `friction`) is an InvalidInput."""
    model = robot.friction
    if model is None:
        raise InvalidInput(
            f"robot '{robot.id}' has no friction model: only a robot "
            "stored by identification has one (its RobotInfo lists "
            "'friction')"
        )
    offset, coulomb, viscous = model["offset"], model["coulomb"], model["viscous"]
    return lambda v: offset + coulomb * np.sign(v) + viscous * v


def forward_dynamics(
    robot: Robot, s: States, *, external_forces: Sequence[Mapping[str, Any]] | None = None
) -> Results:
    """a = M(q)⁻¹ (τ − C(q, v) v − g(q)) by the articulated-body algorithm, (N, nv).

    ABA in Pinocchio's WORLD convention, the one `abaInParallel` uses, so that a batch gives
    bit for bit the same answer however it is computed (LOCAL differs by rounding, ~1e-10).
    With `external_forces` (see `service.dynamics.external_forces`) the answer is
    a = M⁻¹ (τ − C v − g + Σ Jᵀ w)."""
    q, v, tau = s["q"], s["v"], s["tau"]
    out = np.empty((q.shape[0], robot.nv))
    forces = ExternalForces(robot, external_forces, s) if external_forces else None
    world = pin.Convention.WORLD
    with robot.data() as data:
        if forces is None:
            for i in range(q.shape[0]):
                out[i] = pin.aba(robot.model, data, q[i], v[i], tau[i], world)
        else:
            for i in range(q.shape[0]):
                fext = forces.at(data, q[i], i)
                out[i] = pin.aba(robot.model, data, q[i], v[i], tau[i], fext, world)
    return finite("forward-dynamics", a=out)


EQUATION_OF_MOTION = (
    Quantity(
        "mass-matrix",
        ("q",),
        mass_matrix,
        "Mass matrix M(q)",
        answer_size=nv_squared_numbers,
        state_by_state=MASS_MATRIX,
    ),
    Quantity(
        "gravity",
        ("q",),
        gravity,
        "Gravity vector g(q)",
        parallel=parallel.gravity,
        joint_answers=("gravity",),
        answer_size=nv_numbers,
    ),
    Quantity(
        "coriolis",
        ("q", "v"),
        coriolis,
        "Coriolis matrix C(q, v) and forces C v",
        joint_answers=("coriolis_forces",),
        answer_size=lambda r, o, v: r.nv * r.nv + r.nv,
        state_by_state=CORIOLIS,
    ),
    Quantity(
        "nonlinear-effects",
        ("q", "v"),
        nonlinear_effects,
        "Nonlinear effects C(q, v) v + g(q)",
        parallel=parallel.nonlinear_effects,
        finite_in_answer=("v",),
        joint_answers=("nonlinear_effects",),
        answer_size=nv_numbers,
    ),
    Quantity(
        "inverse-dynamics",
        ("q", "v", "a"),
        inverse_dynamics,
        "Inverse dynamics τ = M a + C v + g (RNEA)",
        parallel=parallel.inverse_dynamics,
        finite_in_answer=("v", "a"),
        joint_answers=("tau",),
        answer_size=inverse_dynamics_size,
    ),
    Quantity(
        "forward-dynamics",
        ("q", "v", "tau"),
        forward_dynamics,
        "Forward dynamics a = M⁻¹ (τ − C v − g) (ABA)",
        parallel=parallel.forward_dynamics,
        joint_answers=("a",),
        answer_size=nv_numbers,
    ),
)
