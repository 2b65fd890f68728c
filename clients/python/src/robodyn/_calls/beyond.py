"""Request builders of the quantities beyond the equation of motion: M⁻¹, energy, centre of
mass, frame Jacobians and operational-space dynamics. (The clients' docstrings describe them.)"""

from __future__ import annotations

from typing import Any

import numpy as np

from robodyn._calls.request import array, request
from robodyn.arrays import ArrayLike
from robodyn.contacts import nonnegative
from robodyn.core import Call
from robodyn.payloads import PayloadsLike
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
    return {"frame": frame_name(frame),
            "reference_frame": choice("reference_frame", reference_frame, REFERENCE_FRAMES)}


def mass_matrix_inverse(robot_id: str, q: ArrayLike, *, payloads: PayloadsLike | None = None
                        ) -> Call[np.ndarray]:
    return request(robot_id, "mass-matrix-inverse", array("mass_matrix_inverse", 2),
                   payloads=payloads, q=q)


def energy(robot_id: str, q: ArrayLike, v: ArrayLike, *,
           payloads: PayloadsLike | None = None) -> Call[Energy]:
    return request(robot_id, "energy", Energy.from_json, payloads=payloads, q=q, v=v)


def center_of_mass(robot_id: str, q: ArrayLike, v: ArrayLike | None = None, *,
                   payloads: PayloadsLike | None = None) -> Call[CenterOfMass]:
    return request(robot_id, "center-of-mass", CenterOfMass.from_json, payloads=payloads,
                   optional=("v",), q=q, v=v)


def jacobian(robot_id: str, q: ArrayLike, frame: str, *,
             reference_frame: ReferenceFrame = "local_world_aligned",
             v: ArrayLike | None = None, payloads: PayloadsLike | None = None
             ) -> Call[FrameJacobian]:
    return request(robot_id, "jacobian", FrameJacobian.from_json,
                   _frame(frame, reference_frame), payloads=payloads, optional=("v",),
                   q=q, v=v)


def operational_space(robot_id: str, q: ArrayLike, frame: str, *, v: ArrayLike | None = None,
                      reference_frame: ReferenceFrame = "local_world_aligned",
                      task: Task = "full", damping: float = 0.0,
                      payloads: PayloadsLike | None = None) -> Call[OperationalSpace]:
    options = {**_frame(frame, reference_frame), "task": choice("task", task, TASKS),
               "damping": nonnegative("damping", damping)}
    return request(robot_id, "operational-space", OperationalSpace.from_json, options,
                   payloads=payloads, optional=("v",), q=q, v=v)
