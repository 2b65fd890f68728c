"""Routes of identification: GET /v1/robots/{id}/inertial-parameters and
POST /v1/robots/{id}/identify (the regressor is a dynamics quantity, `service.api.quantities`).

identify is a lean route (like the dynamics routes): its body, a whole log, is parsed and
validated in a worker thread, and the fit runs in the identification worker process
(`service.dynamics.identification.worker`, one fit at a time with a time limit), so the event
loop and /health/live never wait for it. Its OpenAPI description is a twin route
(`openapi_routes`) with the same models.
"""

# No `from __future__ import annotations`: FastAPI must see the twin's request model.
import functools
from typing import Any

import numpy as np
from fastapi import APIRouter, Request, Response
from fastapi.exceptions import RequestValidationError
from pydantic import ValidationError
from starlette.concurrency import run_in_threadpool
from starlette.routing import Route

from service.api.deps import RegistryDep, require_api_key
from service.api.encoding.answers import JSONAnswer, json_bytes
from service.api.progress import ProgressAnswer, progress_channel, wants_progress
from service.api.routes.dynamics import PREFIX, off_loop
from service.api.schemas.common import Problem
from service.api.schemas.identification import (
    IdentifyAnswer,
    IdentifyRequest,
    InertialParameters,
)
from service.dynamics.identification.regressor import inertial_parameters_answer
from service.dynamics.identification.worker import IdentificationWorker
from service.dynamics.payloads import check_payloads
from service.errors import DimensionMismatch, InvalidInput
from service.registry import Registry
from service.registry.robot import Robot
from service.registry.variants import Fitted

router = APIRouter(prefix=PREFIX, tags=["identification"])

_PROBLEMS: dict[int | str, dict[str, Any]] = {
    401: {"model": Problem, "description": "unauthorized (identify stores a model: it needs "
          "a key where keys are set, like an upload)"},
    404: {"model": Problem, "description": "robot_not_found"},
    413: {"model": Problem, "description": "payload_too_large"},
    422: {"model": Problem, "description": "validation_error (NaN, non-increasing t, too few "
          "samples, a motion that reveals too little, over the time limit), "
          "dimension_mismatch, invalid_configuration, unknown_frame (payload), "
          "unsupported_model (a free-flyer or planar base, a multi-DoF joint)"},
    503: {"model": Problem, "description": "not_ready, overloaded (identifications already "
          "running, or the machine too busy to finish within the time limit)"},
}


@router.get("/{robot_id}/inertial-parameters", response_model=InertialParameters,
            responses={404: _PROBLEMS[404]},
            summary="The inertial parameters π of every body (10 per body, joint order)")
async def inertial_parameters(robot_id: str, registry: RegistryDep) -> Response:
    """π = [m, m cx, m cy, m cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] per body, in its joint's frame
    (inertia about the joint origin), stacked in joint order: τ = Y(q, v, a) π + armature ∘ a
    with Y the `regressor`."""
    return JSONAnswer(inertial_parameters_answer(registry.get(robot_id)))


def worker_of(request: Request) -> IdentificationWorker:
    """The app's identification worker (made on first use, from the settings)."""
    state = request.app.state
    worker: IdentificationWorker | None = getattr(state, "identification", None)
    if worker is None:
        settings = state.settings
        worker = IdentificationWorker(settings.identify_timeout_s, settings.identify_memory_mb)
        state.identification = worker
    return worker


def _parse(body: bytes, max_samples: int) -> IdentifyRequest:
    try:
        parsed = IdentifyRequest.model_validate_json(body)
    except ValidationError as exc:
        raise RequestValidationError(
            [{**e, "loc": ("body", *e["loc"])} for e in exc.errors()]) from None
    if len(parsed.t) > max_samples:
        raise DimensionMismatch(f"the log has {len(parsed.t)} samples; the limit is "
                                f"{max_samples} (ROBODYN_MAX_IDENTIFY_SAMPLES): send a "
                                "shorter log or one sampled less often")
    return parsed


def _inputs(parsed: IdentifyRequest) -> dict[str, Any]:
    inputs: dict[str, Any] = {
        "t": parsed.t, "q": parsed.q, "tau": parsed.tau, "friction": parsed.friction,
        "method": parsed.method, "weighted": parsed.weighted,
        "validation_fraction": parsed.validation_fraction, "filter_hz": parsed.filter_hz,
        "payload_frame": None if parsed.payload is None else parsed.payload.frame}
    for name in ("v", "a"):
        if getattr(parsed, name) is not None:
            inputs[name] = getattr(parsed, name)
    return inputs


def identification_answer(result: Any, robot_info: dict[str, Any] | None,
                          include_series: bool, not_stored: str | None = None
                          ) -> dict[str, Any]:
    """The IdentifyAnswer document of an `Identification` (an infinite condition number is
    null)."""
    condition = float(result.condition_number)
    answer = {"not_stored": not_stored,
        "parameters": result.parameters, "bodies": result.bodies, "friction": result.friction,
        "base_parameters": result.base_parameters,
        "condition_number": condition if np.isfinite(condition) else None,
        "physically_consistent": result.physically_consistent, "rmse": result.rmse,
        "filter_hz": result.filter_hz, "samples": result.samples, "robot": robot_info,
        "payload": result.payload}
    if include_series:
        answer["validation_series"] = result.validation
    return answer


def _store(registry: Registry, robot: Robot, result: Any
           ) -> tuple[dict[str, Any] | None, str | None]:
    """Store the identified robot as a variant of `robot`: (its RobotInfo, None), or (None,
    why it was not stored) when the fit is not a physically possible robot."""
    friction = Fitted.from_dict({"friction": result.friction}).friction
    if result.payload is None:
        if not result.physically_consistent:
            return None, ("not stored: these least-squares parameters are not physically "
                          "consistent (a pseudo-inertia has a negative eigenvalue); method "
                          "'physically-consistent' gives parameters that can be stored")
        fitted = Fitted(tuple(float(x) for x in result.parameters), friction)
        stored, _ = registry.variant(robot.id, fitted=fitted,
                                     name=f"{robot.name} (identified)")
        return stored.info(), None
    try:
        payloads = check_payloads(robot, [result.payload])
    except InvalidInput as exc:
        return None, f"not stored: the identified payload is not physically possible ({exc})"
    stored, _ = registry.variant(robot.id, payloads=payloads, fitted=Fitted(None, friction),
                                 name=f"{robot.name} (identified payload)")
    return stored.info(), None


async def identify(request: Request) -> Response | ProgressAnswer:
    """POST /v1/robots/{id}/identify (see `describe_identify` for the documentation); as a
    progress stream of the fit's stages when the `Accept` header asks for it
    (`service.api.progress`)."""
    await require_api_key(request)  # it stores a model (by default), like an upload
    registry: Registry = request.app.state.registry
    robot = registry.get(request.path_params["robot_id"])
    body = await request.body()
    if wants_progress(request.scope):
        async def produce() -> bytes:
            return json_bytes(await _identification(request, registry, robot, body))
        return ProgressAnswer(produce)
    return JSONAnswer(await _identification(request, registry, robot, body))


async def _identification(request: Request, registry: Registry, robot: Robot, body: bytes
                          ) -> dict[str, Any]:
    """The IdentifyAnswer document of `body`: parsed off the loop, fitted in the worker
    process (its stages reported to the request's progress channel, if any), stored."""
    parsed = await off_loop(request, _parse, body, request.app.state.settings.max_identify_samples)
    channel = progress_channel(request.scope)
    fit = functools.partial(worker_of(request).identify, robot,
                            None if channel is None else channel.report, **_inputs(parsed))
    result = await off_loop(request, fit)
    info, not_stored = (await run_in_threadpool(_store, registry, robot, result)
                        if parsed.store else (None, None))
    return identification_answer(result, info, parsed.include_series, not_stored)


def routes() -> list[Route]:
    """The lean serving route of identify."""
    return [Route(f"{PREFIX}/{{robot_id}}/identify", identify, methods=["POST"],
                  name="identify")]


def openapi_routes() -> APIRouter:
    """The documentation twin of identify (never mounted)."""
    twin = APIRouter(prefix=PREFIX, tags=["identification"])

    async def describe_identify(robot_id: str, body: IdentifyRequest) -> None:
        """Fit a fixed-base robot's inertial parameters and friction (or a payload's) to a
        logged motion (t, q, measured τ; v and a optional), check the fit on the held-out
        end of the log, and store the identified robot as a variant. The fit runs in a worker
        process with a time limit (ROBODYN_IDENTIFY_TIMEOUT_S). See docs/identification.md."""
        raise NotImplementedError  # documentation only: `identify` serves the route

    twin.add_api_route("/{robot_id}/identify", describe_identify, methods=["POST"],
                       response_model=IdentifyAnswer, responses=_PROBLEMS, name="identify",
                       summary="Identify inertial parameters and friction from a logged motion")
    return twin
