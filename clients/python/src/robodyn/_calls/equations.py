"""Request builder of the equations of motion in explicit form. (The clients' docstrings
describe it.)"""

from __future__ import annotations

import dataclasses
from urllib.parse import urlencode

from robodyn._calls.request import ROBOT, route_call
from robodyn.core import Call
from robodyn.equations import Equations


def equations(
    robot_id: str, *, form: str = "numeric", digits: int = 6, tolerance: float = 1e-9
) -> Call[Equations]:
    call = route_call(
        "GET", f"{ROBOT}/equations", lambda status, body: Equations.from_json(body), robot_id
    )
    query = {"form": form, "digits": digits, "tolerance": repr(float(tolerance))}
    return dataclasses.replace(call, path=f"{call.path}?{urlencode(query)}")
