"""Request builder of the payload capacity: the heaviest point mass a frame can hold within the
effort limits. (The clients' docstrings describe it.)"""

from __future__ import annotations

from typing import Any

import numpy as np

from robodyn._calls.request import request
from robodyn.arrays import ArrayLike, joint_array, joint_input
from robodyn.core import Call
from robodyn.errors import InputError
from robodyn.payloads import PayloadCapacity, PayloadsLike
from robodyn.request_options import frame_name


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
