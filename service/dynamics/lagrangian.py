"""The Lagrangian view of the dynamics: M(q)⁻¹, the energies T and U, and the centre of mass.

L = T − U with the kinetic energy T = ½ vᵀ M(q) v (armature included, as in M) and the potential
energy U(q) = −Σᵢ mᵢ g₀ᵀ cᵢ(q) of the bodies' centres of mass cᵢ in the gravity field g₀ (zero
at the world origin, so U = m_total · 9.81 · z_com for the default gravity); the gravity vector
of the equation of motion is its gradient, g(q) = ∂U/∂q. Units: J for energies, m for positions.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from service.dynamics.quantity import (
    Quantity,
    Results,
    finite,
    matrix,
    mirror_upper,
    nv_squared_numbers,
)
from service.registry.robot import Robot
from service.states import States


def minverse(robot: Robot, data: object, q: np.ndarray) -> np.ndarray:
    """M(q)⁻¹ at one configuration (nv×nv, symmetric) by Pinocchio's computeMinverse, an
    extension of the articulated-body algorithm: M is never formed nor inverted numerically.
    (The pin 4 binding returns it already mirrored; `mirror_upper` keeps the answer symmetric
    whichever binding runs.)"""
    nv = robot.nv
    return mirror_upper(np.array(matrix(pin.computeMinverse(robot.model, data, q), nv, nv)))


def mass_matrix_inverse(robot: Robot, s: States) -> Results:
    """M(q)⁻¹, (N, nv, nv), symmetric positive definite, in 1/(kg·m²) (1/kg on prismatic
    rows): the map from generalized forces to accelerations, a = M⁻¹ (τ − C v − g)."""
    q = s["q"]
    out = np.empty((q.shape[0], robot.nv, robot.nv))
    with robot.data() as data:
        for i in range(q.shape[0]):
            out[i] = minverse(robot, data, q[i])
    return finite("mass-matrix-inverse", mass_matrix_inverse=out)


def mechanical_energy(
    robot: Robot, data: object, q: np.ndarray, v: np.ndarray
) -> tuple[float, float]:
    """(T, U) in J: the kinetic energy T = ½ vᵀ M(q) v, armature included as in M, and the
    potential energy U of gravity (zero at the world origin), in one pass over the joints.
    Pinocchio's energies (4.x) leave out the armature of some joints (a revolute joint about an
    axis that is not x, y or z: 0.5 · armature · v² missing), so they are computed on the model
    without armature and ½ Σ armature ∘ v² is added. Fills `data`'s kinematics at (q, v)."""
    pin.computeMechanicalEnergy(robot.model_without_armature, data, q, v)
    kinetic = float(data.kinetic_energy)  # type: ignore[attr-defined]
    potential = float(data.potential_energy)  # type: ignore[attr-defined]
    armature = robot.armature
    if armature is not None:
        # Elementwise, not np.dot: a BLAS call releases the GIL, and released and taken back
        # at every step of a rollout it starves the event loop (see dynamics.stopping)
        kinetic += 0.5 * float((armature * v * v).sum())
    return kinetic, potential


def energy(robot: Robot, s: States) -> Results:
    """Kinetic energy T = ½ vᵀ M v, potential energy U (zero at the world origin) and the
    mechanical energy T + U, each (N,) in J. Along any motion d(T + U)/dt = vᵀ τ, with τ the
    applied generalized force (gravity's work is already in U)."""
    q, v = s["q"], s["v"]
    n = q.shape[0]
    T, U = np.empty(n), np.empty(n)
    with robot.data() as data:
        for i in range(n):
            T[i], U[i] = mechanical_energy(robot, data, q[i], v[i])
    return finite("energy", kinetic_energy=T, potential_energy=U, mechanical_energy=T + U)


def center_of_mass(robot: Robot, s: States) -> Results:
    """The centre of mass of the whole robot in the world frame: position c(q), (N, 3) in m,
    its Jacobian J_c(q) = ∂c/∂q, (N, 3, nv), and with v its velocity ċ = J_c v, (N, 3) in
    m/s."""
    q = s["q"]
    v = s.arrays.get("v")
    n = q.shape[0]
    position, jac = np.empty((n, 3)), np.empty((n, 3, robot.nv))
    velocity = np.empty((n, 3)) if v is not None else None
    model = robot.model
    with robot.data() as data:
        for i in range(n):
            jac[i] = matrix(pin.jacobianCenterOfMass(model, data, q[i]), 3, robot.nv)
            if v is None or velocity is None:
                position[i] = pin.centerOfMass(model, data, q[i])
            else:
                position[i] = pin.centerOfMass(model, data, q[i], v[i])
                velocity[i] = data.vcom[0]
    if velocity is None:
        return finite("center-of-mass", position=position, jacobian=jac)
    return finite("center-of-mass", position=position, velocity=velocity, jacobian=jac)


LAGRANGIAN = (
    Quantity(
        "mass-matrix-inverse",
        ("q",),
        mass_matrix_inverse,
        "Inverse mass matrix M(q)⁻¹ (computeMinverse, no numerical inversion)",
        answer_size=nv_squared_numbers,
    ),
    Quantity(
        "energy",
        ("q", "v"),
        energy,
        "Kinetic, potential and mechanical energy",
        answer_size=lambda r, o, v: 3,
    ),
    Quantity(
        "center-of-mass",
        ("q",),
        center_of_mass,
        "Centre of mass position, Jacobian and (with v) velocity",
        optional=("v",),
        answer_size=lambda r, o, v: 3 + 3 * r.nv + (3 if v else 0),
    ),
)
