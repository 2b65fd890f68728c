"""Request builder of operational-space dynamics: Khatib's Λ, J̄, μ and p of a frame's task.
(The clients' docstrings describe it.)"""

from __future__ import annotations

from robodyn._calls.request import request
from robodyn.arrays import ArrayLike
from robodyn.contacts import nonnegative
from robodyn.core import Call
from robodyn.payloads import PayloadsLike
from robodyn.request_options import TASKS, ReferenceFrame, Task, choice, frame_options
from robodyn.results import OperationalSpace


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
        **frame_options(frame, reference_frame),
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
