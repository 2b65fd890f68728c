"""Routes of the dynamics quantities: POST /v1/robots/{id}/<quantity>, one per quantity."""

# No `from __future__ import annotations`: FastAPI must see the closure's request model.
from typing import Any

from fastapi import APIRouter, Depends, Request, Response
from starlette.concurrency import run_in_threadpool

from service import dynamics
from service.api.answers import JSONAnswer
from service.api.deps import get_registry
from service.api.schemas import ANSWER_BY_QUANTITY, REQUEST_BY_INPUTS, Problem
from service.registry import Registry
from service.states import prepare

router = APIRouter(prefix="/v1/robots", tags=["dynamics"])

# Batches bigger than this (states × nv) run in a worker thread, not on the event loop.
INLINE_WORK = 2_000

_PROBLEMS: dict[int | str, dict[str, Any]] = {
    404: {"model": Problem, "description": "robot_not_found"},
    422: {"model": Problem, "description": "validation_error, dimension_mismatch, "
          "invalid_configuration, non_finite_result"},
    503: {"model": Problem, "description": "not_ready"},
}


def _make_endpoint(quantity: dynamics.Quantity) -> Any:
    request_model = REQUEST_BY_INPUTS[quantity.inputs]

    async def endpoint(robot_id: str, body: request_model, request: Request,  # type: ignore[valid-type]
                       registry: Registry = Depends(get_registry)) -> Response:
        robot = registry.get(robot_id)
        inputs = {name: getattr(body, name) for name in quantity.inputs}
        max_batch = request.app.state.settings.max_batch
        states = prepare(robot, inputs, max_batch)
        if states.count * robot.nv <= INLINE_WORK:
            result = dynamics.compute(robot, quantity.path, states)
        else:
            result = await run_in_threadpool(dynamics.compute, robot, quantity.path, states)
        return JSONAnswer(result)

    endpoint.__name__ = quantity.path.replace("-", "_")
    endpoint.__doc__ = quantity.compute.__doc__
    return endpoint


for _quantity in dynamics.QUANTITIES.values():
    router.add_api_route(
        f"/{{robot_id}}/{_quantity.path}", _make_endpoint(_quantity), methods=["POST"],
        response_model=ANSWER_BY_QUANTITY[_quantity.path], responses=_PROBLEMS,
        summary=_quantity.summary, name=_quantity.path)
