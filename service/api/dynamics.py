"""Routes of the dynamics quantities: POST /v1/robots/{id}/<quantity>, one per quantity."""

# No `from __future__ import annotations`: FastAPI must see the closure's request model.
import time
from typing import Any

from fastapi import APIRouter, Request, Response
from starlette.concurrency import run_in_threadpool

from service import dynamics
from service.api.answers import JSONAnswer
from service.api.deps import RegistryDep
from service.api.schemas import ANSWER_BY_QUANTITY, REQUEST_BY_INPUTS, Problem
from service.errors import Overloaded
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


async def _off_loop(request: Request, robot: Any, quantity: str, states: Any) -> Any:
    """Run a large batch in a worker thread; shed load (503 overloaded) past the queue limit."""
    state = request.app.state
    if state.batches_in_flight >= state.settings.max_pending_batches:
        raise Overloaded(f"{state.batches_in_flight} large batches are already being computed; "
                         "retry shortly")
    state.batches_in_flight += 1  # only touched on the event loop: no lock needed
    try:
        return await run_in_threadpool(dynamics.compute, robot, quantity, states)
    finally:
        state.batches_in_flight -= 1


def _make_endpoint(quantity: dynamics.Quantity) -> Any:
    request_model = REQUEST_BY_INPUTS[quantity.inputs]

    async def endpoint(robot_id: str, body: request_model, request: Request,  # type: ignore[valid-type]
                       registry: RegistryDep) -> Response:
        robot = registry.get(robot_id)
        inputs = {name: getattr(body, name) for name in quantity.inputs}
        max_batch = request.app.state.settings.max_batch
        states = prepare(robot, inputs, max_batch)
        started = time.perf_counter()
        if states.count * robot.nv <= INLINE_WORK:
            result = dynamics.compute(robot, quantity.path, states)
        else:
            result = await _off_loop(request, robot, quantity.path, states)
        # For the observability middleware (Server-Timing, access log, compute histogram):
        request.scope["robodyn"] = {"robot": robot_id, "quantity": quantity.path,
                                    "batch_size": states.count,
                                    "compute_seconds": time.perf_counter() - started}
        return JSONAnswer(result)

    endpoint.__name__ = quantity.path.replace("-", "_")
    endpoint.__doc__ = quantity.compute.__doc__
    return endpoint


for _quantity in dynamics.QUANTITIES.values():
    router.add_api_route(
        f"/{{robot_id}}/{_quantity.path}", _make_endpoint(_quantity), methods=["POST"],
        response_model=ANSWER_BY_QUANTITY[_quantity.path], responses=_PROBLEMS,
        summary=_quantity.summary, name=_quantity.path)
