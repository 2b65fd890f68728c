"""Frames of a robot by name: links, joints and fixed frames of its Pinocchio model.

`frame_id` is the one lookup of a client-given frame name; an unknown name is the 422
`unknown_frame`, whose detail says where the valid names are listed (the `frames` of
GET /v1/robots/{id}). The name itself is never echoed back.
"""

from __future__ import annotations

from service.errors import UnknownFrame
from service.registry.robot import Robot


def frame_id(robot: Robot, name: str, field: str = "frame") -> int:
    """The index of frame `name` in `robot.model.frames`; `UnknownFrame` naming the request
    `field` (e.g. "external_forces[0].frame") when the robot has no such frame."""
    if not robot.model.existFrame(name):
        raise UnknownFrame(f"{field} is not a frame of robot '{robot.id}'; the valid names are "
                           f"listed under `frames` in GET /v1/robots/{robot.id}")
    return int(robot.model.getFrameId(name))
