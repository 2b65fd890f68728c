"""Frames of a model and their Jacobians: J(q) and its time variation J̇(q, v).

A frame is any named frame of the model: a link (BODY), a joint (JOINT), a fixed joint
(FIXED_JOINT) or an operational frame; `GET /v1/robots/{id}` lists them under `frames`. Where a
name is shared (a link and a joint of the same name), the link's body frame is meant.

The frame Jacobian J (6×nv) maps the joint velocity v to the frame's spatial velocity J v =
[linear (m/s); angular (rad/s)], linear first, expressed in `reference_frame`:

- `"local"`: the frame's own axes; the linear part is the velocity of the frame's origin.
- `"local_world_aligned"` (default): the world's axes at the frame's origin; the linear part is
  the velocity of the frame's origin in world coordinates (what a Cartesian controller uses).
- `"world"`: the world frame; the linear part is the velocity of the point of the body that
  coincides with the world origin (Featherstone's spatial velocity).

J̇ is the time derivative of that same matrix along the motion (q, v): the frame's acceleration
in the same reference frame is J a + J̇ v.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
import pinocchio as pin

from service.dynamics.quantity import Quantity, Results, finite, matrix
from service.errors import UnknownFrame, did_you_mean
from service.registry.robot import Robot
from service.states import States

ReferenceFrame = Literal["world", "local", "local_world_aligned"]

REFERENCE_FRAMES: dict[str, Any] = {
    "world": pin.ReferenceFrame.WORLD,
    "local": pin.ReferenceFrame.LOCAL,
    "local_world_aligned": pin.ReferenceFrame.LOCAL_WORLD_ALIGNED,
}

_SHOWN_NAME_LENGTH = 64  # longer (or unprintable) unknown names are not echoed back


def frame_id(robot: Robot, name: str, field: str = "frame") -> int:
    """The index of the frame called `name`; `UnknownFrame` (saying where the names are) if
    the model has none. `field` is the request member that gave the name, named in the error
    when it is not the plain `frame` (e.g. "external_forces[1].frame")."""
    fid = robot.frame_ids.get(name)  # its body frame, else the first of that name
    if fid is not None:
        return fid
    shown = (
        f"'{name}'" if len(name) <= _SHOWN_NAME_LENGTH and name.isprintable() else "of that name"
    )
    where = "" if field == "frame" else f" (in {field})"
    close = did_you_mean(name, (frame.name for frame in robot.model.frames))
    raise UnknownFrame(
        f"robot '{robot.id}' has no frame {shown}{close}{where}; the valid names "
        f"are listed under `frames` of GET /v1/robots/{robot.id} (links, joints and "
        "fixed frames)"
    )


def frame_jacobian(
    robot: Robot, data: Any, q: np.ndarray, fid: int, reference: Any, v: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray | None]:
    """J (6×nv) of frame `fid` at one configuration q, and with v also J̇ (6×nv), in the
    Pinocchio reference frame `reference`. Uses `data`; copies are returned."""
    model, nv = robot.model, robot.nv
    if v is None:
        return matrix(pin.computeFrameJacobian(model, data, q, fid, reference), 6, nv), None
    pin.computeJointJacobiansTimeVariation(model, data, q, v)
    pin.updateFramePlacements(model, data)
    J = matrix(pin.getFrameJacobian(model, data, fid, reference), 6, nv)
    dJ = matrix(pin.getFrameJacobianTimeVariation(model, data, fid, reference), 6, nv)
    return J, dJ


def jacobian(
    robot: Robot, s: States, *, frame: str, reference_frame: ReferenceFrame = "local_world_aligned"
) -> Results:
    """J(q) of `frame`, shape (N, 6, nv): rows [linear (m/s per unit of v); angular (rad/s per
    unit of v)] in `reference_frame`; with v also J̇(q, v), (N, 6, nv), 1/s times the units
    of J. The frame's velocity is J v and its acceleration J a + J̇ v."""
    fid = frame_id(robot, frame)
    reference = REFERENCE_FRAMES[reference_frame]
    q = s["q"]
    v = s.arrays.get("v")
    n = q.shape[0]
    J = np.empty((n, 6, robot.nv))
    dJ = np.empty((n, 6, robot.nv)) if v is not None else None
    with robot.data() as data:
        for i in range(n):
            J[i], dJ_i = frame_jacobian(
                robot, data, q[i], fid, reference, None if v is None else v[i]
            )
            if dJ is not None:
                dJ[i] = dJ_i
    if dJ is None:
        return finite("jacobian", jacobian=J)
    return finite("jacobian", jacobian=J, jacobian_time_variation=dJ)


FRAMES = (
    Quantity(
        "jacobian",
        ("q",),
        jacobian,
        "Frame Jacobian J(q) and, with v, its time variation J̇(q, v)",
        optional=("v",),
        answer_size=lambda r, o, v: 6 * r.nv * (2 if v else 1),
    ),
)
