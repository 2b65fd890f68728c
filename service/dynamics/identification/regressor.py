"""The joint torque regressor Y(q, v, a) and the friction columns appended to it.

RNEA is linear in the inertial parameters π (see `parameters`):

    τ = Y(q, v, a) π + armature ∘ a

with Y of shape (nv, 10 · bodies) (Pinocchio's `computeJointTorqueRegressor`; gravity is the
model's) and the armature (rotor inertia reflected through the gear, known, not identified) on
the diagonal of M. Friction adds, per 1-DoF joint j, a torque linear in its parameters:

    τ_f,j = offset_j + coulomb_j sign(v_j) + viscous_j v_j     (N·m or N; sign(0) = 0)

Friction models: "none" (the offset alone), "viscous" (offset + viscous),
"coulomb-viscous" (all three). Their columns F(v) (nv, 3 or 2 or 1 per joint) are appended to Y.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from service.dynamics.identification.parameters import (
    LAYOUT,
    PER_BODY,
    body_names,
    inertial_parameters,
)
from service.dynamics.quantity import Quantity, Results, finite
from service.errors import InvalidInput
from service.registry.robot import Robot
from service.states import States

FRICTION_MODELS: dict[str, tuple[str, ...]] = {
    "none": ("offset",),
    "viscous": ("viscous", "offset"),
    "coulomb-viscous": ("coulomb", "viscous", "offset"),
}
DEFAULT_FRICTION = "coulomb-viscous"


def friction_terms(friction: str) -> tuple[str, ...]:
    """The friction parameters each joint gets under a friction model (see above)."""
    try:
        return FRICTION_MODELS[friction]
    except KeyError:
        shown = ", ".join(f"'{k}'" for k in FRICTION_MODELS)
        raise InvalidInput(f"friction must be one of {shown}") from None


def friction_names(joints: list[str], friction: str) -> list[str]:
    """ "<joint>.<term>" for each friction parameter, joint after joint."""
    return [f"{joint}.{term}" for joint in joints for term in friction_terms(friction)]


def joint_torque_regressor(
    model: Any,
    data: Any,
    q: np.ndarray,
    v: np.ndarray,
    a: np.ndarray,
    columns: np.ndarray | None = None,
) -> np.ndarray:
    """Y for N states: q (N, nq), v and a (N, nv) → (N, nv, 10 · bodies), or only the given
    `columns` of it (N, nv, len(columns)). SI units: τ = Y π in N·m (N for prismatic joints)."""
    count = q.shape[0]
    width = PER_BODY * (model.njoints - 1) if columns is None else len(columns)
    out = np.empty((count, model.nv, width))
    for i in range(count):
        y = pin.computeJointTorqueRegressor(model, data, q[i], v[i], a[i])
        y = y.reshape(model.nv, -1)  # a 1-DoF robot's regressor may come back 1-D
        out[i] = y if columns is None else y[:, columns]
    return out


def regressor(robot: Robot, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Y(q, v, a) of a robot for N states (N, nv, 10 · bodies); q in Pinocchio's order."""
    with robot.data() as data:
        return joint_torque_regressor(robot.model, data, q, v, a)


def joint_torque_regressors(robot: Robot, s: States) -> Results:
    """The joint torque regressor Y(q, v, a) of each state, (N, nv, 10 · bodies): τ = Y π +
    armature ∘ a with π the inertial parameters (`parameters.inertial_parameters`, 10 per
    body in joint order: m in kg, m c in kg·m, the inertia about the joint origin in kg·m²);
    Y's entries are in the units that make Y π N·m (or N for a prismatic joint's row)."""
    return finite("regressor", regressor=regressor(robot, s["q"], s["v"], s["a"]))


def friction_columns(v: np.ndarray, friction: str) -> np.ndarray:
    """F(v): (N, nv, nv · terms), τ_f = F(v) φ with φ = [joint 0's terms, joint 1's, ...]
    in the order of `FRICTION_MODELS[friction]`."""
    terms = friction_terms(friction)
    count, nv = v.shape
    out = np.zeros((count, nv, nv * len(terms)))
    for j in range(nv):
        for k, term in enumerate(terms):
            col = j * len(terms) + k
            if term == "offset":
                out[:, j, col] = 1.0
            elif term == "viscous":
                out[:, j, col] = v[:, j]
            else:
                out[:, j, col] = np.sign(v[:, j])
    return out


def friction_torque(
    v: np.ndarray, coulomb: np.ndarray, viscous: np.ndarray, offset: np.ndarray
) -> np.ndarray:
    """τ_f = offset + coulomb ∘ sign(v) + viscous ∘ v for velocities v (N, nv) or (nv,)."""
    friction: np.ndarray = offset + coulomb * np.sign(v) + viscous * v
    return friction


def inertial_parameters_answer(robot: Robot) -> dict[str, Any]:
    """`{"bodies", "layout", "parameters"}`: the bodies (joint names, joint order), the names
    of the 10 numbers per body, and π (10 · bodies,) of the robot's model."""
    return {
        "bodies": body_names(robot.model),
        "layout": list(LAYOUT),
        "parameters": inertial_parameters(robot.model),
    }


REGRESSOR = (
    Quantity(
        "regressor",
        ("q", "v", "a"),
        joint_torque_regressors,
        "Joint torque regressor Y(q, v, a), linear in the inertial parameters: "
        "τ = Y π + armature ∘ a",
        answer_size=lambda r, o, v: r.nv * PER_BODY * (r.model.njoints - 1),
    ),
)
