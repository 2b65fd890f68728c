"""Routes of identification: GET /v1/robots/{id}/inertial-parameters and
POST /v1/robots/{id}/identify (the regressor is a dynamics quantity, `service.api.quantities`).

identify is a lean route (like the dynamics routes): its body, a whole log, JSON or the binary
form (a safetensors file: t, q, tau, v, a as F64 tensors, the options as JSON texts in
`__metadata__`, see docs/binary-format.md; the answer is JSON either way), is parsed and
validated in a worker thread, and the fit runs in the identification worker process
(`service.api.workers.identification`, one fit at a time, a bounded queue, a time limit),
awaited on the event loop: the event loop and /health/live never wait for it, and neither does
a worker thread (the off-loop slots large batches need stay free). A client that disconnects
stops its fit at once (`_fitted`). Its OpenAPI description is a twin route (`openapi_routes`)
with the same models.
"""

# No `from __future__ import annotations`: FastAPI must see the twin's request model.
import asyncio
from typing import Any

import numpy as np
from fastapi import APIRouter, Request, Response
from fastapi.exceptions import RequestValidationError
from pydantic import ValidationError, create_model
from starlette.concurrency import run_in_threadpool
from starlette.routing import Route

from service.api.cancellation import STOPPED
from service.api.deps import RegistryDep, require_api_key, served_robot
from service.api.encoding import binary
from service.api.encoding.answers import JSONAnswer, json_bytes
from service.api.json_bodies import ISOLATED_JSON_BYTES, parse_isolated
from service.api.progress import ProgressAnswer, progress_channel, wants_progress
from service.api.routes.dynamics import PREFIX, off_loop
from service.api.schemas.common import Problem, StrictRequest, many_unknown_members
from service.api.schemas.identification import (
    IdentifyAnswer,
    IdentifyRequest,
    InertialParameters,
)
from service.api.workers.identification import IdentificationWorker
from service.dynamics.identification.pipeline import Identification, Progress
from service.dynamics.identification.regressor import inertial_parameters_answer
from service.dynamics.payloads import check_payloads
from service.errors import (
    ComputationStopped,
    DimensionMismatch,
    InvalidInput,
    UnsupportedMediaType,
)
from service.registry import Registry
from service.registry.robot import Robot
from service.registry.variants import Fitted

router = APIRouter(prefix=PREFIX, tags=["identification"])

_PROBLEMS: dict[int | str, dict[str, Any]] = {
    401: {
        "model": Problem,
        "description": "unauthorized (identify stores a model: it needs "
        "a key where keys are set, like an upload)",
    },
    404: {"model": Problem, "description": "robot_not_found"},
    413: {"model": Problem, "description": "payload_too_large"},
    415: {
        "model": Problem,
        "description": "unsupported_media_type (neither JSON nor the binary form)",
    },
    422: {
        "model": Problem,
        "description": "validation_error (NaN, non-increasing t, too few "
        "samples, a motion that reveals too little, over the time limit), "
        "dimension_mismatch, invalid_configuration, unknown_frame (payload), "
        "unsupported_model (a free-flyer or planar base, a multi-DoF joint)",
    },
    503: {
        "model": Problem,
        "description": "not_ready, overloaded (identifications already "
        "running and waiting, the machine too busy to finish within the time limit, or "
        "the worker killed from outside, e.g. out of memory)",
    },
}


@router.get(
    "/{robot_id}/inertial-parameters",
    response_model=InertialParameters,
    responses={404: _PROBLEMS[404]},
    summary="The inertial parameters π of every body (10 per body, joint order)",
)
async def inertial_parameters(robot_id: str, registry: RegistryDep) -> Response:
    """π = [m, m cx, m cy, m cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] per body, in its joint's frame
    (inertia about the joint origin), stacked in joint order: τ = Y(q, v, a) π + armature ∘ a
    with Y the `regressor`."""
    return JSONAnswer(inertial_parameters_answer(await served_robot(registry, robot_id)))


def worker_of(request: Request) -> IdentificationWorker:
    """The app's identification worker (made on first use, from the settings)."""
    state = request.app.state
    worker: IdentificationWorker | None = getattr(state, "identification", None)
    if worker is None:
        settings = state.settings
        worker = IdentificationWorker(settings.identify_timeout_s, settings.identify_memory_mb)
        state.identification = worker
    return worker


LOG_ARRAYS = ("t", "q", "tau", "v", "a")  # the log's arrays: tensors in the binary form
_REQUIRED_ARRAYS = ("t", "q", "tau")
_OPTION_FIELDS: dict[str, Any] = {
    name: (info.annotation, info)
    for name, info in IdentifyRequest.model_fields.items()
    if name not in LOG_ARRAYS
}
_Options = create_model(  # the other members of IdentifyRequest: `__metadata__` in binary
    "IdentifyOptions", __base__=StrictRequest, **_OPTION_FIELDS
)


def _invalid(exc: ValidationError) -> RequestValidationError:
    return RequestValidationError([{**e, "loc": ("body", *e["loc"])} for e in exc.errors()])


def _log_arrays(arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The tensors of a binary body checked as the JSON form's fields are: t 1-D, the others
    2-D (one row per sample), every number finite. Widths and row counts are checked against
    the robot with the log (`motion_log`), as for JSON."""
    for name, array in arrays.items():
        ndim, shape = (1, "[N]") if name == "t" else (2, "[N, nq]" if name == "q" else "[N, nv]")
        if array.ndim != ndim:
            raise InvalidInput(
                f"binary body: tensor {name} has shape {list(array.shape)}; it "
                f"must be {shape} (one {'time' if ndim == 1 else 'row'} per "
                "sample)"
            )
        bad = np.flatnonzero(~np.isfinite(array.reshape(-1)))
        if bad.size:
            where = np.unravel_index(int(bad[0]), array.shape)
            raise InvalidInput(
                f"binary body: {name}[{', '.join(str(int(i)) for i in where)}] "
                f"is {array[where]}; every number must be finite"
            )
    return arrays


def _parse_binary(body: bytes) -> IdentifyRequest:
    """The request of a binary body: its tensors (`_log_arrays`) and its `__metadata__`
    validated by the JSON form's model for the other members (strict, unknown names refused)."""
    fields, arrays = binary.decode(body)
    misplaced = [name for name in LOG_ARRAYS if name in fields]
    unknown = sorted(set(arrays) - set(LOG_ARRAYS))
    missing = [name for name in _REQUIRED_ARRAYS if name not in arrays]
    takes = "identify takes the tensors t, q, tau and optional v, a (F64)"
    if misplaced:
        raise InvalidInput(
            f"binary body: {misplaced[0]} is in __metadata__; it goes as a tensor ({takes})"
        )
    if unknown or missing:
        wrong = f"unknown tensor {unknown[0]!r}" if unknown else f"missing tensor {missing[0]!r}"
        raise InvalidInput(f"binary body: {wrong}; {takes}")
    many = many_unknown_members(_Options.model_fields, fields)  # counted, not one error each
    if many is not None:
        raise InvalidInput(
            f"binary body: __metadata__ has {many[0]} names that are not fields "
            f"of identify (the first: {many[1]!r})"
        )
    try:
        options = _Options.model_validate(fields)
    except ValidationError as exc:
        raise _invalid(exc) from None
    values: dict[str, Any] = {name: getattr(options, name) for name in _Options.model_fields}
    values.update(_log_arrays(arrays))
    # Not validated again: the arrays were checked above, the options by the same fields.
    return IdentifyRequest.model_construct({*options.model_fields_set, *arrays}, **values)


def _parse_json(body: bytes) -> IdentifyRequest:
    try:
        return IdentifyRequest.model_validate_json(body)
    except ValidationError as exc:
        raise _invalid(exc) from None


def _parse_json_log(body: bytes) -> IdentifyRequest:
    """`_parse_json` with the log's arrays as float64 arrays (as the helper process of large
    bodies sends them back, `service.api.json_bodies`)."""
    parsed = _parse_json(body)
    values = {name: getattr(parsed, name) for name in IdentifyRequest.model_fields}
    values.update(
        {
            name: np.asarray(values[name], dtype=np.float64)
            for name in LOG_ARRAYS
            if values[name] is not None
        }
    )
    return IdentifyRequest.model_construct(parsed.model_fields_set, **values)


def _parse(body: bytes, max_samples: int, content_type: str = "") -> IdentifyRequest:
    """The request of a body in JSON or (by `content_type`) the binary form."""
    media_type = content_type.lower()
    if media_type.startswith(binary.BINARY_MEDIA_TYPE):
        parsed = _parse_binary(body)
    elif media_type and "json" not in media_type.split(";")[0]:
        raise UnsupportedMediaType(
            "send the log as JSON ('Content-Type: application/json') or in the binary form "
            f"('Content-Type: {binary.BINARY_MEDIA_TYPE}')"
        )
    elif len(body) > ISOLATED_JSON_BYTES:  # parsing holds the GIL: in another process
        parsed = parse_isolated(_parse_json_log, body)
    else:
        parsed = _parse_json(body)
    if len(parsed.t) > max_samples:
        raise DimensionMismatch(
            f"the log has {len(parsed.t)} samples; the limit is "
            f"{max_samples} (ROBODYN_MAX_IDENTIFY_SAMPLES): send a "
            "shorter log or one sampled less often"
        )
    return parsed


def _inputs(parsed: IdentifyRequest) -> dict[str, Any]:
    inputs: dict[str, Any] = {
        "t": parsed.t,
        "q": parsed.q,
        "tau": parsed.tau,
        "friction": parsed.friction,
        "method": parsed.method,
        "weighted": parsed.weighted,
        "validation_fraction": parsed.validation_fraction,
        "filter_hz": parsed.filter_hz,
        "payload_frame": None if parsed.payload is None else parsed.payload.frame,
    }
    for name in ("v", "a"):
        if getattr(parsed, name) is not None:
            inputs[name] = getattr(parsed, name)
    return inputs


def identification_answer(
    result: Any,
    robot_info: dict[str, Any] | None,
    include_series: bool,
    not_stored: str | None = None,
) -> dict[str, Any]:
    """The IdentifyAnswer document of an `Identification` (an infinite condition number is
    null)."""
    condition = float(result.condition_number)
    answer = {
        "not_stored": not_stored,
        "parameters": result.parameters,
        "bodies": result.bodies,
        "friction": result.friction,
        "warnings": result.warnings,
        "base_parameters": result.base_parameters,
        "condition_number": condition if np.isfinite(condition) else None,
        "physically_consistent": result.physically_consistent,
        "rmse": result.rmse,
        "filter_hz": result.filter_hz,
        "samples": result.samples,
        "robot": robot_info,
        "payload": result.payload,
    }
    if include_series:
        answer["validation_series"] = result.validation
    return answer


def _store(
    registry: Registry, robot: Robot, result: Any
) -> tuple[dict[str, Any] | None, str | None]:
    """Store the identified robot as a variant of `robot`: (its RobotInfo, None), or (None,
    why it was not stored) when the fit is not a physically possible robot."""
    # (a joint whose motion does not determine its friction has none: no row)
    known = [row for row in result.friction if row is not None]
    friction = Fitted.from_dict({"friction": known}).friction
    if result.payload is None:
        if not result.physically_consistent:
            return None, (
                "not stored: these least-squares parameters are not physically "
                "consistent (a pseudo-inertia has a negative eigenvalue); method "
                "'physically-consistent' gives parameters that can be stored"
            )
        fitted = Fitted(tuple(float(x) for x in result.parameters), friction, result.uncertainty)
        stored, _ = registry.variant(robot.id, fitted=fitted, name=f"{robot.name} (identified)")
        return stored.info(), None
    try:
        payloads = check_payloads(robot, [result.payload])
    except InvalidInput as exc:
        return None, f"not stored: the identified payload is not physically possible ({exc})"
    stored, _ = registry.variant(
        robot.id,
        payloads=payloads,
        fitted=Fitted(None, friction),
        name=f"{robot.name} (identified payload)",
    )
    return stored.info(), None


async def identify(request: Request) -> Response | ProgressAnswer:
    """POST /v1/robots/{id}/identify (see `describe_identify` for the documentation); as a
    progress stream of the fit's stages when the `Accept` header asks for it
    (`service.api.progress`)."""
    await require_api_key(request)  # it stores a model (by default), like an upload
    registry: Registry = request.app.state.registry
    robot = await served_robot(registry, request.path_params["robot_id"])
    body = await request.body()
    if wants_progress(request.scope):

        async def produce() -> bytes:
            return json_bytes(await _identification(request, registry, robot, body))

        return ProgressAnswer(produce)
    return JSONAnswer(await _identification(request, registry, robot, body))


async def _identification(
    request: Request, registry: Registry, robot: Robot, body: bytes
) -> dict[str, Any]:
    """The IdentifyAnswer document of `body`: parsed off the loop, fitted in the worker
    process (its stages reported to the request's progress channel, if any), stored."""
    parsed = await off_loop(
        request,
        _parse,
        body,
        request.app.state.settings.max_identify_samples,
        request.headers.get("content-type", ""),
    )
    channel = progress_channel(request.scope)
    progress = None if channel is None else channel.report
    result = await _fitted(request, robot, progress, _inputs(parsed))
    info, not_stored = (
        await run_in_threadpool(_store, registry, robot, result) if parsed.store else (None, None)
    )
    return identification_answer(result, info, parsed.include_series, not_stored)


async def _client_gone(request: Request) -> None:
    """Returns when the client disconnects (its body is read: the next ASGI message of the
    request is the disconnect)."""
    while (await request.receive()).get("type") != "http.disconnect":
        pass


async def _fitted(
    request: Request, robot: Robot, progress: Progress | None, inputs: dict[str, Any]
) -> Identification:
    """The worker's fit of `inputs`, awaited on the event loop; when the client disconnects
    first (or this request is cancelled), the fit leaves the worker's queue or, running, is
    stopped at once: its worker process is killed and replaced."""
    fit = asyncio.ensure_future(worker_of(request).identify(robot, progress, **inputs))
    gone = asyncio.ensure_future(_client_gone(request))
    try:
        await asyncio.wait({fit, gone}, return_when=asyncio.FIRST_COMPLETED)
        if fit.done():
            return fit.result()
        STOPPED["disconnect"] += 1
        raise ComputationStopped("identify: stopped, the client closed the connection")
    finally:
        gone.cancel()
        fit.cancel()  # no effect once done


def routes() -> list[Route]:
    """The lean serving route of identify."""
    return [Route(f"{PREFIX}/{{robot_id}}/identify", identify, methods=["POST"], name="identify")]


def openapi_routes() -> APIRouter:
    """The documentation twin of identify (never mounted)."""
    twin = APIRouter(prefix=PREFIX, tags=["identification"])

    async def describe_identify(robot_id: str, body: IdentifyRequest) -> None:
        """Fit a fixed-base robot's inertial parameters and friction (or a payload's) to a
        logged motion (t, q, measured τ; v and a optional), check the fit on the held-out
        end of the log, and store the identified robot as a variant. `warnings` names every
        joint whose motion does not determine its friction (it barely moves, or its speed
        stays near zero): its friction entry is null and the variant adds none on it. The fit
        runs in a worker process with a time limit (ROBODYN_IDENTIFY_TIMEOUT_S). See
        docs/identification.md.

        The log may also be sent in the binary form ({media_type}: t, q, tau, v, a as F64
        tensors, the other members as JSON texts in `__metadata__`; see
        docs/binary-format.md); the answer is JSON either way."""
        raise NotImplementedError  # documentation only: `identify` serves the route

    describe_identify.__doc__ = (describe_identify.__doc__ or "").replace(
        "{media_type}", binary.BINARY_MEDIA_TYPE
    )
    binary_body = {
        "schema": {
            "type": "string",
            "format": "binary",
            "description": "The same members as the JSON form: t, q, tau, v, a as float64 tensors, "
            "the others in __metadata__ (see docs/binary-format.md).",
        }
    }
    twin.add_api_route(
        "/{robot_id}/identify",
        describe_identify,
        methods=["POST"],
        response_model=IdentifyAnswer,
        responses=_PROBLEMS,
        name="identify",
        summary="Identify inertial parameters and friction from a logged motion",
        openapi_extra={
            "x-binary-media-type": binary.BINARY_MEDIA_TYPE,
            "requestBody": {"content": {binary.BINARY_MEDIA_TYPE: binary_body}},
        },
    )
    return twin
