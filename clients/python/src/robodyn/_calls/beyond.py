"""Request builders of the quantities beyond the equation of motion: M⁻¹, energy, centre of
mass, frame Jacobians, operational-space dynamics and the payload capacity. (The clients'
docstrings describe them.)"""

from __future__ import annotations

from typing import Any

import numpy as np

from robodyn._calls.request import array, request
from robodyn.arrays import ArrayLike, joint_array, joint_input
from robodyn.contacts import nonnegative
from robodyn.core import Call
from robodyn.errors import InputError
from robodyn.payloads import PayloadCapacity, PayloadsLike
from robodyn.request_options import (
    REFERENCE_FRAMES,
    TASKS,
    ReferenceFrame,
    Task,
    choice,
    frame_name,
)
from robodyn.results import CenterOfMass, Energy, FrameJacobian, OperationalSpace


def _frame(frame: Any, reference_frame: Any) -> dict[str, str]:
    return {
        "frame": frame_name(frame),
        "reference_frame": choice("reference_frame", reference_frame, REFERENCE_FRAMES),
    }


def mass_matrix_inverse(
    robot_id: str, q: ArrayLike, *, payloads: PayloadsLike | None = None
) -> Call[np.ndarray]:
    return request(
        robot_id, "mass-matrix-inverse", array("mass_matrix_inverse", 2), payloads=payloads, q=q
    )


def energy(
    robot_id: str, q: ArrayLike, v: ArrayLike, *, payloads: PayloadsLike | None = None
) -> Call[Energy]:
    return request(robot_id, "energy", Energy.from_json, payloads=payloads, q=q, v=v)


def center_of_mass(
    robot_id: str, q: ArrayLike, v: ArrayLike | None = None, *, payloads: PayloadsLike | None = None
) -> Call[CenterOfMass]:
    return request(
        robot_id,
        "center-of-mass",
        CenterOfMass.from_json,
        payloads=payloads,
        optional=("v",),
        q=q,
        v=v,
    )


def jacobian(
    robot_id: str,
    q: ArrayLike,
    frame: str,
    *,
    reference_frame: ReferenceFrame = "local_world_aligned",
    v: ArrayLike | None = None,
    payloads: PayloadsLike | None = None,
) -> Call[FrameJacobian]:
    return request(
        robot_id,
        "jacobian",
        FrameJacobian.from_json,
        _frame(frame, reference_frame),
        payloads=payloads,
        optional=("v",),
        q=q,
        v=v,
    )


def operational_space(
    robot_id: str,
    q: ArrayLike,
    frame: str,
    *,
    v: ArrayLike | None = None,
    reference_frame: ReferenceFrame = "local_world_aligned",
    task: Task = "full",
    damping: float = 0.0,
    payloads: PayloadsLike | None = None,
) -> Call[OperationalSpace]:
    options = {
        **_frame(frame, reference_frame),
        "task": choice("task", task, TASKS),
        "damping": nonnegative("damping", damping),
    }
    return request(
        robot_id,
        "operational-space",
        OperationalSpace.from_json,
        options,
        payloads=payloads,
        optional=("v",),
        q=q,
        v=v,
    )


def payload_capacity(
    robot_id: str,
    q: ArrayLike,
    frame: str,
    *,
    center_of_mass: ArrayLike | None = None,
    v: ArrayLike | None = None,
    a: ArrayLike | None = None,
    effort_limits: Any = None,
    payloads: PayloadsLike | None = None,
) -> Call[PayloadCapacity]:
    options: dict[str, Any] = {"frame": frame_name(frame)}
    if center_of_mass is not None:
        com = joint_array("center_of_mass", center_of_mass)
        if com.shape != (3,):
            raise InputError(
                f"center_of_mass must have 3 entries (m, in the frame), not shape {com.shape}"
            )
        options["center_of_mass"] = com.tolist()
    if effort_limits is not None:
        limits = joint_input("effort_limits", effort_limits)
        if isinstance(limits, np.ndarray) and (limits.ndim != 1 or (limits < 0).any()):
            raise InputError(
                "effort_limits must be one value ≥ 0 per velocity coordinate "
                "(N·m or N; 0: no limit)"
            )
        options["effort_limits"] = limits.tolist() if isinstance(limits, np.ndarray) else limits
    # the batch's minimum is over every state: one request, never chunks
    return request(
        robot_id,
        "payload-capacity",
        PayloadCapacity.from_json,
        options,
        payloads=payloads,
        optional=("v", "a"),
        independent_rows=False,
        q=q,
        v=v,
        a=a,
    )
