"""Inertial parameters: Pinocchio's 10 numbers per body, to and from a model.

A body is what a joint moves (Pinocchio's `model.inertias[j]`, the joint's child link and every
link fixed to it). Its inertial parameters, in the frame of its joint (at the joint origin):

    π = [m, m cx, m cy, m cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]

m in kg, c the centre of mass in m, h = m c the first moment in kg·m, and Ī the rotational
inertia about the joint frame's origin (not about c) in kg·m²:
Ī = I_c + m (‖c‖² 1 − c cᵀ) (parallel axes). The robot's vector stacks the bodies in joint order
(length 10 · bodies), and the joint torques are linear in it: τ = Y(q, v, a) π (see
`regressor`).

A body is physically realizable (a non-negative mass density can have these moments) exactly
when its 4×4 pseudo-inertia is positive semidefinite:

    J(π) = [[Σ, h], [hᵀ, m]],   Σ = ½ tr(Ī) 1 − Ī  (the second moment ∫ r rᵀ dm),

which implies m ≥ 0, I_c ⪰ 0 and the triangle inequalities of the principal moments.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from service.registry.variants import with_parameters

LAYOUT: tuple[str, ...] = ("m", "m_cx", "m_cy", "m_cz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
PER_BODY = len(LAYOUT)


def body_names(model: Any) -> list[str]:
    """The bodies in the parameter vector's order: the names of their joints."""
    return [str(model.names[j]) for j in range(1, model.njoints)]


def parameter_names(model: Any) -> list[str]:
    """ "<joint>.<layout name>" for each of the 10 · bodies entries of π."""
    return [f"{body}.{name}" for body in body_names(model) for name in LAYOUT]


def inertial_parameters(model: Any) -> np.ndarray:
    """π of the model, shape (10 · bodies,), in the layout above (Pinocchio's
    `Inertia.toDynamicParameters`, body after body in joint order)."""
    return np.concatenate(
        [
            np.asarray(model.inertias[j].toDynamicParameters(), dtype=float)
            for j in range(1, model.njoints)
        ]
    )


def rotational_inertia(pi_body: np.ndarray) -> np.ndarray:
    """Ī (3×3, kg·m², about the joint origin) from one body's 10 parameters."""
    _, _, _, _, xx, xy, yy, xz, yz, zz = pi_body
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def pseudo_inertia(pi_body: np.ndarray) -> np.ndarray:
    """J(π) = [[½ tr(Ī) 1 − Ī, h], [hᵀ, m]] (4×4) of one body's 10 parameters."""
    inertia = rotational_inertia(pi_body)
    out = np.empty((4, 4))
    out[:3, :3] = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    out[:3, 3] = out[3, :3] = pi_body[1:4]
    out[3, 3] = pi_body[0]
    return out


def pseudo_inertia_min_eigenvalues(pi: np.ndarray) -> np.ndarray:
    """The smallest eigenvalue of each body's pseudo-inertia (kg·m² for the moments' block;
    ≥ 0 for a physically realizable body), shape (bodies,)."""
    bodies = pi.reshape(-1, PER_BODY)
    return np.array([float(np.linalg.eigvalsh(pseudo_inertia(b))[0]) for b in bodies])


def body_summary(name: str, pi_body: np.ndarray) -> dict[str, Any]:
    """`{"name", "mass", "center_of_mass", "inertia", "pseudo_inertia_min_eigenvalue"}` of one
    body: mass m (kg), c = h / m (m, in the joint frame; zero when m = 0), inertia about c
    I_c = Ī − m (‖c‖² 1 − c cᵀ) (3×3, kg·m², joint frame axes)."""
    mass = float(pi_body[0])
    com = pi_body[1:4] / mass if mass != 0.0 else np.zeros(3)
    at_com = rotational_inertia(pi_body) - mass * (
        float(com @ com) * np.eye(3) - np.outer(com, com)
    )
    return {
        "name": name,
        "mass": mass,
        "center_of_mass": com,
        "inertia": at_com,
        "pseudo_inertia_min_eigenvalue": float(np.linalg.eigvalsh(pseudo_inertia(pi_body))[0]),
    }


def with_inertial_parameters(model: Any, pi: np.ndarray) -> Any:
    """A copy of `model` whose bodies carry the parameters π (10 · bodies,); the shared model
    is never mutated. A massless body (m = 0) keeps its rotational inertia about the joint
    origin and no centre of mass (a first moment without mass has no rigid body: it is
    dropped; a physically consistent π never has one). (The variants' own composition,
    `service.registry.variants.with_parameters`.)"""
    return with_parameters(model, pi)


def transform_parameters(placement: Any) -> np.ndarray:
    """The 10×10 matrix T with π_joint = T π_frame: a body's parameters given about the origin
    and in the axes of a frame placed at `placement` (SE3: rotation R, translation p, frame in
    joint coordinates) → the same body's parameters in the joint frame. Linear in π:

        m' = m,   h' = R h + m p,
        Ī' = R Ī Rᵀ − m [p]ײ − [p]× [R h]× − [R h]× [p]×.
    """
    rotation = np.asarray(placement.rotation, dtype=float)
    p = np.asarray(placement.translation, dtype=float)
    out = np.empty((PER_BODY, PER_BODY))
    for k in range(PER_BODY):
        unit = np.zeros(PER_BODY)
        unit[k] = 1.0
        out[:, k] = _moved(unit, rotation, p)
    return out


def _skew(x: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -x[2], x[1]], [x[2], 0.0, -x[0]], [-x[1], x[0], 0.0]])


def _moved(pi_body: np.ndarray, rotation: np.ndarray, p: np.ndarray) -> np.ndarray:
    mass, h = pi_body[0], pi_body[1:4]
    rh = rotation @ h
    sp, srh = _skew(p), _skew(rh)
    inertia = (
        rotation @ rotational_inertia(pi_body) @ rotation.T - mass * sp @ sp - sp @ srh - srh @ sp
    )
    h_new = rh + mass * p
    return np.array(
        [
            mass,
            *h_new,
            inertia[0, 0],
            inertia[0, 1],
            inertia[1, 1],
            inertia[0, 2],
            inertia[1, 2],
            inertia[2, 2],
        ]
    )
