"""Request builder of a frame's Jacobian J(q) and its time variation J̇(q, v). (The clients'
docstrings describe it.)"""

from __future__ import annotations

from robodyn._calls.request import request
from robodyn.arrays import ArrayLike
from robodyn.core import Call
from robodyn.payloads import PayloadsLike
from robodyn.request_options import ReferenceFrame, frame_options
from robodyn.results import FrameJacobian


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
        frame_options(frame, reference_frame),
        payloads=payloads,
        optional=("v",),
        q=q,
        v=v,
    )
