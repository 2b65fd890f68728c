"""Inertial parameters of every body of a robot, for `GET /v1/robots/{id}/inertias`.

A body is the rigid body a joint moves: the joint's child link together with every link fixed
to it (Pinocchio merges them, and so does the dynamics). For each one, in the frame of its
joint (the frame the joint's motion is expressed in, at the joint origin):

- `mass` m (kg) and `center_of_mass` c (m);
- `inertia_at_center_of_mass` I_c (3×3, kg·m²), the rotational inertia about c;
- `inertia_at_joint` I_o = I_c + m (‖c‖² 1 − c cᵀ), the same about the joint origin by the
  parallel-axis theorem;
- `principal_moments` (ascending, kg·m²) and `principal_axes` R (3×3, a proper rotation whose
  columns are the axes, in the joint frame), so that I_c = R diag(moments) Rᵀ.

Links fixed to the world (a fixed-base robot's base) do not move, take no part in the dynamics
and are not listed; `total_mass` is the sum of the listed masses, RobotInfo's `total_mass`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from service.registry.robot import Robot


def parallel_axis(inertia_at_com: np.ndarray, mass: float, com: np.ndarray) -> np.ndarray:
    """I_o = I_c + m (‖c‖² 1 − c cᵀ): the inertia about the origin of a body of mass m whose
    inertia about its centre of mass c is I_c (kg·m²)."""
    return inertia_at_com + mass * (float(com @ com) * np.eye(3) - np.outer(com, com))


def principal(inertia_at_com: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(moments ascending, R) with I = R diag(moments) Rᵀ and R a proper rotation (det +1)."""
    moments, axes = np.linalg.eigh(inertia_at_com)
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return moments, axes


def body_inertias(robot: Robot) -> dict[str, Any]:
    """`{"total_mass", "bodies": [...]}`, one body per joint in model order (see above)."""
    model = robot.model
    links: dict[int, list[str]] = {}
    for frame in model.frames:
        if frame.type == pin.FrameType.BODY:
            links.setdefault(int(frame.parentJoint), []).append(frame.name)
    bodies = []
    for jid in range(1, model.njoints):
        inertia = model.inertias[jid]
        mass = float(inertia.mass)
        com = np.array(inertia.lever, dtype=float)
        at_com = np.array(inertia.inertia, dtype=float)
        at_com = 0.5 * (at_com + at_com.T)
        moments, axes = principal(at_com)
        carried = links.get(jid, [])
        bodies.append(
            {
                "name": carried[0] if carried else model.names[jid],
                "joint": model.names[jid],
                "links": carried,
                "mass": mass,
                "center_of_mass": com,
                "inertia_at_center_of_mass": at_com,
                "inertia_at_joint": parallel_axis(at_com, mass, com),
                "principal_moments": moments,
                "principal_axes": axes,
            }
        )
    return {"total_mass": float(sum(b["mass"] for b in bodies)), "bodies": bodies}
