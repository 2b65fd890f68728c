"""World placements of frames: where each link (or any named frame) is for a configuration q.

For each state, Pinocchio's `framesForwardKinematics` gives oMf, the placement of every frame in
the world frame: a position p (m, the frame's origin in world coordinates) and a rotation R (3×3,
the frame's axes as columns in world coordinates), so a point x given in the frame is at
p + R x in the world. `GET /v1/robots/{id}/visuals` gives each link's visuals relative to its
body frame, so these placements are what moves a picture of the robot.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from service.dynamics.frames import frame_id
from service.dynamics.quantity import Quantity, finite
from service.registry.robot import Robot
from service.states import States


def body_frames(robot: Robot) -> tuple[list[str], list[int]]:
    """Names and indices of the model's body frames (one per link), in model order."""
    pairs = [(f.name, i) for i, f in enumerate(robot.model.frames) if f.type == pin.FrameType.BODY]
    return [name for name, _ in pairs], [i for _, i in pairs]


def frame_placements(robot: Robot, s: States, *, frames: list[str] | None = None) -> dict[str, Any]:
    """World placements of `frames` (default: every body frame) for each q: `positions`
    (N, F, 3) in m and `rotations` (N, F, 3, 3), the world placement oMf = (R, p) of each frame
    (a point x of the frame is at p + R x), and `frames`, the F names, once."""
    if frames is None:
        names, ids = body_frames(robot)
    else:
        names = list(frames)
        ids = [frame_id(robot, name, f"frames[{k}]") for k, name in enumerate(frames)]
    q = s["q"]
    n, count = q.shape[0], len(ids)
    positions = np.empty((n, count, 3))
    rotations = np.empty((n, count, 3, 3))
    model = robot.model
    with robot.data() as data:
        placements: Any = data.oMf
        for i in range(n):
            pin.framesForwardKinematics(model, data, q[i])
            for k, fid in enumerate(ids):
                placement = placements[fid]
                positions[i, k] = placement.translation
                rotations[i, k] = placement.rotation
    results: dict[str, Any] = finite("frame-placements", positions=positions, rotations=rotations)
    return {"frames": names, **results}


def placements_work(robot: Robot, s: States, options: dict[str, Any]) -> int:
    """Cost in state×dof units: one forward kinematics per state plus one copy per frame."""
    frames = options.get("frames")
    count = len(robot.model.frames) if frames is None else len(frames)
    return s.count * (robot.nv + count)


def placements_size(robot: Robot, options: dict[str, Any], with_v: bool) -> int:
    """A position (3) and a rotation (3×3) per frame: the body frames, or the named ones."""
    frames = options.get("frames")
    return 12 * (len(body_frames(robot)[0]) if frames is None else len(frames))


PLACEMENTS = (
    Quantity(
        "frame-placements",
        ("q",),
        frame_placements,
        "World placements of the body frames (or the named frames) for q",
        work=placements_work,
        answer_size=placements_size,
    ),
)
