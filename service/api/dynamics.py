"""Routes of the dynamics quantities: POST /v1/robots/{id}/<quantity>, one per quantity.

This is the hot path, so each route is a plain ASGI endpoint without per-request dependency
injection: the body is validated by the quantity's strict pydantic model straight from its bytes
(`model_validate_json`), or decoded from the binary form (`service.api.binary`), and the answer
is written by orjson or the binary encoder. The OpenAPI document describes these routes with
the very same models (`openapi_routes`), and failures are the same problem+json answers.
"""

# No `from __future__ import annotations`: FastAPI must see the closures' request models.
import time
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np
from fastapi import APIRouter, Request, Response
from fastapi.exceptions import RequestValidationError
from pydantic import BaseModel, ValidationError, create_model
from starlette.concurrency import run_in_threadpool
from starlette.requests import HTTPConnection
from starlette.routing import Route

from service import dynamics, joint_names
from service.api import (
    binary,
    schemas_contacts,
    schemas_derivatives,
    schemas_dynamics,
    schemas_operational,
    schemas_options,
    schemas_placements,
    schemas_simulation,
)
from service.api.answer_size import (
    BINARY_BYTES_PER_NUMBER,
    JSON_BYTES_PER_NUMBER,
    check_answer_size,
    key_bytes,
)
from service.api.answers import JSONAnswer, json_bytes, json_pieces
from service.api.deps import check_api_key_for_all
from service.api.schemas import Problem
from service.errors import InvalidInput, Overloaded, UnsupportedMediaType
from service.states import prepare

T = TypeVar("T")
PREFIX = "/v1/robots"
REQUESTS: dict[str, type[BaseModel]] = {
    path: schemas_options.with_joint_names(model) for path, model in {
        **schemas_dynamics.REQUESTS, **schemas_options.REQUESTS, **schemas_operational.REQUESTS,
        **schemas_derivatives.REQUESTS, **schemas_simulation.REQUESTS,
        **schemas_contacts.REQUESTS, **schemas_placements.REQUESTS}.items()}
ANSWERS: dict[str, type[BaseModel]] = {
    **schemas_dynamics.ANSWERS, **schemas_options.ANSWERS, **schemas_operational.ANSWERS,
    **schemas_derivatives.ANSWERS, **schemas_simulation.ANSWERS,
    **schemas_contacts.ANSWERS, **schemas_placements.ANSWERS}

# Batches bigger than this (states × nv) are validated, computed and encoded in a worker thread,
# and JSON bodies bigger than INLINE_BODY_BYTES parsed there: on the event loop they would
# stall every other request (a 10,000-state Talos JSON body takes ~0.25 s to parse).
INLINE_WORK = 2_000
INLINE_BODY_BYTES = 64 * 1024

_PROBLEMS: dict[int | str, dict[str, Any]] = {
    404: {"model": Problem, "description": "robot_not_found"},
    415: {"model": Problem, "description": "unsupported_media_type"},
    422: {"model": Problem, "description": "validation_error, dimension_mismatch, "
          "invalid_configuration, non_finite_result (and the quantity's own codes)"},
    503: {"model": Problem, "description": "not_ready, overloaded"},
}


async def off_loop(request: HTTPConnection, fn: Callable[..., T], *args: Any) -> T:
    """Run `fn(*args)` (a large batch's work) in a worker thread; shed load (503 overloaded)
    past `max_pending_batches` in flight."""
    state = request.app.state
    if state.batches_in_flight >= state.settings.max_pending_batches:
        raise Overloaded(f"{state.batches_in_flight} large batches are already being computed; "
                         "retry shortly")
    state.batches_in_flight += 1  # only touched on the event loop: no lock needed
    try:
        return await run_in_threadpool(fn, *args)
    finally:
        state.batches_in_flight -= 1


def _rows(arrays: dict[str, Any]) -> int:
    """The number of states of the inputs, cheaply (before validation; 1 when unsure)."""
    q = arrays.get("q")
    if isinstance(q, np.ndarray):
        return q.shape[0] if q.ndim == 2 else 1
    return len(q) if isinstance(q, list) and q and isinstance(q[0], list | dict) else 1


def _prepare(robot: Any, arrays: dict[str, Any], max_batch: int, fill: str | None = None
             ) -> Any:
    """The validated `States` of the inputs; name-keyed ones become arrays first (missing
    joints filled from the configuration named `fill`, if given)."""
    if joint_names.any_named(arrays):  # a type check: plain arrays pay nothing measurable
        arrays = joint_names.arrays_from_names(robot, arrays, fill)
    elif fill is not None:
        joint_names.fill_values(robot, fill, "nq")  # an unknown name is an error all the same
    return prepare(robot, arrays, max_batch)


def _media_types(headers: list[tuple[bytes, bytes]]) -> tuple[str, str]:
    """(Content-Type, Accept) of raw ASGI headers, "" where absent: one pass over the list
    (Starlette's `Headers.get` scans it once per name)."""
    content_type = accept = None
    for name, value in headers:
        if name == b"content-type" and content_type is None:  # the first one, as Starlette
            content_type = value.decode("latin-1").lower()  # media types ignore case
        elif name == b"accept" and accept is None:
            accept = value.decode("latin-1").lower()
    return content_type or "", accept or ""


def _invalid(exc: ValidationError) -> RequestValidationError:
    return RequestValidationError([{**e, "loc": ("body", *e["loc"])} for e in exc.errors()])


class Endpoint:
    """The endpoint of one quantity: `answer` takes the Starlette request."""

    def __init__(self, quantity: dynamics.Quantity) -> None:
        self.quantity = quantity
        self.route = Route(f"{PREFIX}/{{robot_id}}/{quantity.path}", self.answer,
                           methods=["POST"], name=quantity.path)
        self.model = REQUESTS[quantity.path]
        self.joint_inputs = (*quantity.inputs, *quantity.optional)
        fields: dict[str, Any] = {
            name: (info.annotation, info) for name, info in self.model.model_fields.items()
            if name not in self.joint_inputs}
        self.options_model = create_model(  # the non-array fields, for binary bodies
            f"{self.model.__name__}Options", __config__=self.model.model_config, **fields)

    def parse_json(self, body: bytes | bytearray | str
                   ) -> tuple[dict[str, Any], dict[str, Any]]:
        """(joint-space arrays, options) of a JSON body."""
        try:
            parsed = self.model.model_validate_json(body)
        except ValidationError as exc:
            raise _invalid(exc) from None
        return self._split(parsed)

    def parse_object(self, body: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
        """(joint-space arrays, options) of an already decoded JSON object."""
        try:
            parsed = self.model.model_validate(body)
        except ValidationError as exc:
            raise _invalid(exc) from None
        return self._split(parsed)

    def _split(self, parsed: BaseModel) -> tuple[dict[str, Any], dict[str, Any]]:
        arrays = {n: getattr(parsed, n) for n in self.joint_inputs if getattr(parsed, n, None)
                  is not None}
        given = parsed.model_fields_set.difference(self.joint_inputs)
        return arrays, (parsed.model_dump(include=given) if given else {})

    def parse_binary(self, fields: dict[str, Any], arrays: dict[str, Any]
                     ) -> tuple[dict[str, Any], dict[str, Any]]:
        """(joint-space arrays, options) of a decoded binary body (`binary.decode`)."""
        unknown = sorted(set(arrays) - set(self.joint_inputs))
        missing = [n for n in self.quantity.inputs if n not in arrays]
        if unknown or missing:
            wrong = (f"unknown array {unknown[0]!r}" if unknown else
                     f"missing array {missing[0]!r}")
            raise InvalidInput(f"binary body: {wrong}; {self.quantity.path} takes "
                               f"the arrays {', '.join(self.joint_inputs)}")
        try:
            options = self.options_model.model_validate(fields)
        except ValidationError as exc:
            raise _invalid(exc) from None
        given = options.model_fields_set
        return arrays, (options.model_dump(include=given) if given else {})

    async def compute(self, request: HTTPConnection, robot: Any, arrays: dict[str, Any],
                      options: dict[str, Any],
                      bytes_per_number: int = JSON_BYTES_PER_NUMBER) -> dict[str, Any]:
        """Validate the states, check the answer's size against the budget
        (`service.api.answer_size`, at `bytes_per_number`) and compute: inline when small, in a
        worker thread when large. Name-keyed inputs become arrays first (`fill` fills missing
        joints); with `"joint_names": true` the joint-space answers are keyed by joint name.
        Records what was computed in the ASGI scope (`scope["robodyn"]`) for logs and
        Server-Timing."""
        named = options.pop("joint_names", False) if options else False
        fill = options.pop("fill", None) if options else None
        settings = request.app.state.settings
        for setting in self.quantity.settings:
            options[setting] = getattr(settings, setting)
        started = time.perf_counter()
        work = self.quantity.work
        if named and self.quantity.joint_answers:  # each number then also carries its key
            bytes_per_number += key_bytes(robot)
        budget = (bytes_per_number, settings.max_answer_bytes)
        large = work is None and _rows(arrays) * robot.nv > INLINE_WORK
        if large:
            states, result = await off_loop(request, self._prepare_and_run, robot, arrays,
                                             options, settings.max_batch, budget, fill)
        else:
            states = _prepare(robot, arrays, settings.max_batch, fill)
            self._check_size(robot, states, options, budget)
            large = (states.count * robot.nv if work is None else work(robot, states, options)
                     ) > INLINE_WORK
            if large:
                result = await off_loop(request, dynamics.run, robot, self.quantity, states,
                                         options)
            else:
                result = dynamics.run(robot, self.quantity, states, options)
        request.scope["robodyn"] = {
            "robot": robot.id, "quantity": self.quantity.path, "batch_size": states.count,
            "compute_seconds": time.perf_counter() - started, "large": large}
        if named:
            result = joint_names.by_name(robot, result, self.quantity.joint_answers)
        return result

    def _prepare_and_run(self, robot: Any, arrays: dict[str, Any], options: dict[str, Any],
                         max_batch: int, budget: tuple[int, int], fill: str | None = None
                         ) -> tuple[Any, dict[str, Any]]:
        states = _prepare(robot, arrays, max_batch, fill)
        self._check_size(robot, states, options, budget)
        return states, dynamics.run(robot, self.quantity, states, options)

    def _check_size(self, robot: Any, states: Any, options: dict[str, Any],
                    budget: tuple[int, int]) -> None:
        """413 before computing an answer over `ROBODYN_MAX_ANSWER_BYTES` (single states of
        fixed-size quantities are far below it: not checked, the hot path stays as it was)."""
        if states.count > 1 or self.quantity.work is not None:
            check_answer_size(self.quantity.path, robot, options, "v" in states.arrays,
                              states.count, *budget)

    async def handle(self, request: HTTPConnection, body: bytes | bytearray
                     ) -> tuple[bytes | list[bytes], str]:
        """The answer to `body` (JSON or binary) as (content, media type), content in pieces
        for a large JSON answer; domain errors and validation errors are raised for the app's
        exception handlers."""
        check_api_key_for_all(request)
        robot = request.app.state.registry.get(request.path_params["robot_id"])
        content_type, accept = _media_types(request.scope["headers"])
        if content_type.startswith(binary.BINARY_MEDIA_TYPE):
            arrays, options = self.parse_binary(*binary.decode(body))
        elif content_type and "json" not in content_type.split(";")[0]:
            raise UnsupportedMediaType(
                "send the body as JSON ('Content-Type: application/json') or in the binary "
                f"form ('Content-Type: {binary.BINARY_MEDIA_TYPE}')")
        elif len(body) > INLINE_BODY_BYTES:
            arrays, options = await off_loop(request, self.parse_json, body)
        else:
            arrays, options = self.parse_json(body)
        as_binary = binary.BINARY_MEDIA_TYPE in accept
        result = await self.compute(request, robot, arrays, options,
                                    BINARY_BYTES_PER_NUMBER if as_binary else JSON_BYTES_PER_NUMBER)
        media_type = binary.BINARY_MEDIA_TYPE if as_binary else JSONAnswer.media_type
        if request.scope["robodyn"]["large"]:
            # In a worker thread (~0.1 s for 10k mass matrices); JSON in pieces, each encoded
            # in one short call, so the event loop gets the GIL in between and the pieces are
            # written as the client reads them.
            encode_large = binary.encode if as_binary else json_pieces
            content: bytes | list[bytes] = await off_loop(request, encode_large, result)
        else:
            content = binary.encode(result) if as_binary else json_bytes(result)
        return content, media_type

    async def answer(self, request: Request) -> Response:
        """The Starlette endpoint (`service.api.fast_path` calls `handle` directly)."""
        request.scope["route"] = self.route  # FastAPI's router records only its own routes
        content, media_type = await self.handle(request, await request.body())
        return Response(content if isinstance(content, bytes) else b"".join(content),
                        media_type=media_type)


# Built once: an endpoint holds no per-app state (it reads the app from each request).
ENDPOINTS: dict[str, Endpoint] = {q.path: Endpoint(q) for q in dynamics.QUANTITIES.values()}


def routes() -> list[Route]:
    """The serving routes, one per quantity."""
    return [endpoint.route for endpoint in ENDPOINTS.values()]


def openapi_routes() -> APIRouter:
    """Routes that only describe the serving routes in the OpenAPI document (never mounted)."""
    router = APIRouter(prefix=PREFIX, tags=["dynamics"])
    for quantity in dynamics.QUANTITIES.values():
        router.add_api_route(
            f"/{{robot_id}}/{quantity.path}", _describe(quantity), methods=["POST"],
            response_model=ANSWERS[quantity.path], responses=_PROBLEMS,
            summary=quantity.summary, name=quantity.path,
            openapi_extra={"x-binary-media-type": binary.BINARY_MEDIA_TYPE})
    return router


def _describe(quantity: dynamics.Quantity) -> Any:
    request_model = REQUESTS[quantity.path]

    async def endpoint(robot_id: str, body: request_model) -> None:  # type: ignore[valid-type]
        raise NotImplementedError  # documentation only: Endpoint serves the route

    endpoint.__name__ = quantity.path.replace("-", "_")
    endpoint.__doc__ = (f"{quantity.compute.__doc__}\n\nThe body may also be sent, and the answer "
                        f"asked for, in the binary form ({binary.BINARY_MEDIA_TYPE}, see "
                        "docs/binary-format.md).")
    return endpoint
