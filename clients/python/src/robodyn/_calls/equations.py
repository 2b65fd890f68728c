"""Request builder of the equations of motion in explicit form. (The clients' docstrings
describe it.)"""

from __future__ import annotations

from robodyn._calls.request import ROBOT, route_call
from robodyn.core import Call
from robodyn.equations import Equations


def equations(robot_id: str) -> Call[Equations]:
    return route_call(
        "GET", f"{ROBOT}/equations", lambda status, body: Equations.from_json(body), robot_id
    )
