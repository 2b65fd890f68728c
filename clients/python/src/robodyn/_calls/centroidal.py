"""Request builder of the centroidal momentum and its matrix. (The clients' docstrings describe
it.)"""

from __future__ import annotations

from robodyn._calls.request import request
from robodyn.arrays import ArrayLike
from robodyn.core import Call
from robodyn.payloads import PayloadsLike
from robodyn.results import Centroidal


def centroidal(
    robot_id: str, q: ArrayLike, v: ArrayLike, *, payloads: PayloadsLike | None = None
) -> Call[Centroidal]:
    return request(robot_id, "centroidal", Centroidal.from_json, payloads=payloads, q=q, v=v)
