"""Request builders of the model check (`GET /v1/robots/{id}/model-check`)."""

from __future__ import annotations

from robodyn._calls.request import ROBOT, route_call
from robodyn.core import Call
from robodyn.model_check import ModelCheck


def model_check(robot_id: str) -> Call[ModelCheck]:
    return route_call(
        "GET", f"{ROBOT}/model-check", lambda status, body: ModelCheck.from_json(body), robot_id
    )
