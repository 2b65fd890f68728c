"""Routes of the dynamics quantities: POST /v1/robots/{id}/<quantity>, one per quantity,
each derived from its spec (`service.api.quantities.SPECS`).

This is the hot path, so each route is a plain ASGI endpoint without per-request dependency
injection: the body is validated by the quantity's strict pydantic model straight from its bytes
(`model_validate_json`), or decoded from the binary form (`service.api.encoding.binary`), and
the answer is written by orjson or the binary encoder. The OpenAPI document describes these
routes with the very same models (`openapi_routes`), and failures are the same problem+json answers.
"""

# No `from __future__ import annotations`: FastAPI must see the closures' request models.
import asyncio
import contextvars
import functools
import time
from collections.abc import Callable
from concurrent.futures import Executor
from typing import Any, NamedTuple, TypeVar

import numpy as np
from fastapi import APIRouter, Request, Response
from fastapi.exceptions import RequestValidationError
from pydantic import BaseModel, ValidationError, create_model
from starlette.concurrency import run_in_threadpool
from starlette.requests import HTTPConnection
from starlette.routing import Route

from service import dynamics
from service.api import inputs
from service.api.cancellation import cancellable
from service.api.deps import check_api_key_for_all, served_robot
from service.api.encoding import binary
from service.api.encoding.accept import prefers
from service.api.encoding.answers import JSONAnswer, json_bytes, json_pieces
from service.api.encoding.budget import check_answer_size
from service.api.encoding.in_flight import ANSWER_BYTES, release_answer_bytes
from service.api.encoding.shared_bodies import AnswerWriter, over_unix_socket
from service.api.json_bodies import ISOLATED_JSON_BYTES, compact, parse_isolated
from service.api.problems.validation_errors import json_prefix, prefix_errors, pydantic_errors
from service.api.progress import Produce, ProgressAnswer, wants_progress
from service.api.quantities import SPECS, Spec
from service.api.schemas.common import Problem, StrictRequest, many_unknown_members
from service.dynamics.parallel import OPENMP_MASTER
from service.errors import InvalidInput, Overloaded, UnsupportedMediaType

T = TypeVar("T")
PREFIX = "/v1/robots"

# Batches bigger than this (states × nv) are validated, computed and encoded in a worker thread,
# and JSON bodies bigger than INLINE_BODY_BYTES parsed there: on the event loop they would
# stall every other request (a 10,000-state Talos JSON body takes ~0.25 s to parse).
INLINE_WORK = 2_000
# An answer of more numbers than this (about 0.6 MB of JSON) is computed and encoded off the
# event loop however little work it is (a regressor of a few states of a humanoid).
INLINE_ANSWER_NUMBERS = 32_768
INLINE_BODY_BYTES = 64 * 1024

_PROBLEMS: dict[int | str, dict[str, Any]] = {
    404: {"model": Problem, "description": "robot_not_found"},
    415: {"model": Problem, "description": "unsupported_media_type"},
    422: {
        "model": Problem,
        "description": "validation_error, dimension_mismatch, "
        "invalid_configuration, non_finite_result (and the quantity's own codes)",
    },
    503: {"model": Problem, "description": "not_ready, overloaded"},
    504: {"model": Problem, "description": "deadline_exceeded"},
}


async def off_loop(
    request: HTTPConnection, fn: Callable[..., T], *args: Any, executor: Executor | None = None
) -> T:
    """Run `fn(*args)` (a large batch's work) in a worker thread (or in `executor`, in a copy
    of the request's context), at most as many at once as the process has CPUs (the others
    wait their turn on the event loop: Python code and Pinocchio hold the GIL, so more
    threads would only take turns with the event loop's); shed load (503 overloaded) past
    `max_pending_batches` computed or waiting."""
    state = request.app.state
    if state.batches_in_flight >= state.settings.max_pending_batches:
        raise Overloaded(
            f"{state.batches_in_flight} large batches are already being computed; retry shortly"
        )
    state.batches_in_flight += 1  # only touched on the event loop: no lock needed
    try:
        async with state.off_loop_slots:  # a few at once: the loop keeps its share of the GIL
            if executor is None:
                return await run_in_threadpool(fn, *args)
            run = functools.partial(contextvars.copy_context().run, fn, *args)
            return await asyncio.get_running_loop().run_in_executor(executor, run)
    finally:
        state.batches_in_flight -= 1


def _batch_split(connection: HTTPConnection) -> Any:
    """The process's `BatchSplit` for this request's large mass-matrix and Coriolis batches
    (`service.api.workers.batch_split`), or None: with ROBODYN_BATCH_HELPERS unset, only
    requests over the Unix socket share their batches with the helpers."""
    state = connection.app.state
    if state.batch_split is None or (
        state.split_over_socket_only and not over_unix_socket(connection.scope)
    ):
        return None
    return state.batch_split


class _Sizing(NamedTuple):
    """How a request's answer is sized: its connection, the answer budget, its form."""

    connection: HTTPConnection
    limit: int
    binary: bool
    named: bool


def _rows(arrays: dict[str, Any]) -> int:
    """The number of states of the inputs, cheaply (before validation; 1 when unsure)."""
    q = arrays.get("q")
    if isinstance(q, np.ndarray):
        return q.shape[0] if q.ndim == 2 else 1
    return len(q) if isinstance(q, list) and q and isinstance(q[0], list | dict) else 1


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


def _invalid(
    exc: ValidationError, model: type[BaseModel], data: Callable[[], Any], partial: bool = False
) -> RequestValidationError:
    """The request error of a failed validation by `model`, with at most a few hundred error
    objects built whatever the number of mistakes (`pydantic_errors`; `data()`: the body, or
    with `partial` its beginning, as decoded JSON, read again only then)."""
    return RequestValidationError(
        [{**e, "loc": ("body", *e["loc"])} for e in pydantic_errors(exc, model, data, partial)]
    )


class Endpoint:
    """The endpoint of one quantity: `answer` takes the Starlette request."""

    def __init__(self, spec: Spec) -> None:
        self.quantity = quantity = spec.quantity
        self.route = Route(
            f"{PREFIX}/{{robot_id}}/{quantity.name}",
            self.answer,
            methods=["POST"],
            name=quantity.name,
        )
        self.model = spec.request
        self.joint_inputs = (*quantity.inputs, *quantity.optional)
        fields: dict[str, Any] = {
            name: (info.annotation, info)
            for name, info in self.model.model_fields.items()
            if name not in self.joint_inputs
        }
        self.options_model = create_model(  # the non-array fields, for binary bodies
            f"{self.model.__name__}Options", __base__=StrictRequest, **fields
        )

    def parse_json(self, body: bytes | bytearray | str) -> tuple[dict[str, Any], dict[str, Any]]:
        """(joint-space arrays, options) of a JSON body. A large body whose beginning already
        shows mistakes is refused with them, before the whole of it is validated."""
        if len(body) > INLINE_BODY_BYTES:
            errors = prefix_errors(self.model, body)
            if errors:
                raise RequestValidationError([{**e, "loc": ("body", *e["loc"])} for e in errors])
        try:
            parsed = self.model.model_validate_json(body)
        except ValidationError as exc:
            raise _invalid(exc, self.model, lambda: json_prefix(body), partial=True) from None
        arrays, options = self._split(parsed)
        self.refuse_repeated_names(body, arrays, options)
        return arrays, options

    def refuse_repeated_names(
        self, body: bytes | bytearray | str, arrays: dict[str, Any], options: dict[str, Any]
    ) -> None:
        """422 for a joint named twice in a name-keyed input of the JSON `body` (checked only
        when some input is keyed by name)."""
        if inputs.names_keyed(self.quantity, arrays, options):
            inputs.refuse_repeated_names(body)

    def parse_object(self, body: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
        """(joint-space arrays, options) of an already decoded JSON object."""
        many = many_unknown_members(self.model.model_fields, body)  # counted, not listed
        if many is not None:
            raise InvalidInput(
                f"the message has {many[0]} members that are not fields of "
                f"{self.quantity.name} (the first: {many[1]!r})"
            )
        try:
            parsed = self.model.model_validate(body)
        except ValidationError as exc:
            raise _invalid(exc, self.model, lambda: body) from None
        return self._split(parsed)

    def _split(self, parsed: BaseModel) -> tuple[dict[str, Any], dict[str, Any]]:
        arrays = {
            n: getattr(parsed, n) for n in self.joint_inputs if getattr(parsed, n, None) is not None
        }
        given = parsed.model_fields_set.difference(self.joint_inputs)
        return arrays, (parsed.model_dump(include=given) if given else {})

    def parse_binary(
        self, fields: dict[str, Any], arrays: dict[str, Any]
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """(joint-space arrays, options) of a decoded binary body (`binary.decode`). An option
        of one number per sample (`Quantity.tensor_options`) may come as a 1-D tensor."""
        for name in self.quantity.tensor_options:
            if name in arrays:
                tensor = arrays.pop(name)  # (`binary.decode` refuses it in both places)
                if tensor.ndim != 1:
                    raise InvalidInput(
                        f"binary body: tensor {name} has shape "
                        f"{list(tensor.shape)}; it must be 1-D, one number per "
                        "sample"
                    )
                fields = {**fields, name: tensor.tolist()}
        unknown = sorted(set(arrays) - set(self.joint_inputs))
        missing = [n for n in self.quantity.inputs if n not in arrays]
        if unknown or missing:
            wrong = f"unknown array {unknown[0]!r}" if unknown else f"missing array {missing[0]!r}"
            raise InvalidInput(
                f"binary body: {wrong}; {self.quantity.name} takes "
                f"the arrays {', '.join(self.joint_inputs)}"
            )
        allowed = self.options_model.model_fields
        many = many_unknown_members(allowed, fields)  # counted, not one error each
        if many is not None:
            raise InvalidInput(
                f"binary body: __metadata__ has {many[0]} names that are not "
                f"fields of this request (the first: {many[1]!r}); "
                f"{self.quantity.name} takes {', '.join(allowed)}"
            )
        try:
            options = self.options_model.model_validate(fields)
        except ValidationError as exc:
            raise _invalid(exc, self.options_model, lambda: fields) from None
        given = options.model_fields_set
        return arrays, (options.model_dump(include=given) if given else {})

    async def compute(
        self,
        request: HTTPConnection,
        robot: Any,
        arrays: dict[str, Any],
        options: dict[str, Any],
        as_binary: bool = False,
    ) -> dict[str, Any]:
        """Validate the states, check the answer's size against the budget
        (`service.api.encoding.budget`, for the form asked for) and compute: inline when
        small, in a worker thread when large, stoppable there by the request's deadline and
        its client's disconnect (`service.api.cancellation`). Name-keyed inputs and options
        become arrays first (`fill` fills missing joints); with `"joint_names": true` the
        joint-space answers are keyed by joint name (in the binary form: arrays, with their
        joint layout once). The robot computed with is `inputs.robot_for(robot, options)`.
        Records what was computed in the ASGI scope (`scope["robodyn"]`) for logs and
        Server-Timing."""
        named = options.pop("joint_names", False) if options else False
        fill = options.pop("fill", None) if options else None
        if options:
            robot = inputs.robot_for(robot, options)
            if self.quantity.named_options:
                options = inputs.options_from_names(robot, self.quantity, options)
        settings = request.app.state.settings
        for setting in self.quantity.settings:
            options[setting] = getattr(settings, setting)
        started = time.perf_counter()
        work = self.quantity.work
        sizing = _Sizing(request, settings.max_answer_bytes, as_binary, named)
        # Many states × nv: validated (a copy and checks of every number) off the event loop
        # too. A quantity's own work estimate is at least states × nv, so it would be computed
        # there anyway; with fewer, the estimate decides once the states are validated.
        large = _rows(arrays) * robot.nv > INLINE_WORK
        if large:
            # A batch with a parallel form (no options) is validated and computed in the OpenMP
            # master thread, where it is computed anyway: one thread hop fewer each way.
            in_master = dynamics.has_parallel_form(self.quantity, options)
            async with cancellable(request, self.quantity.name) as stop:
                states, result = await off_loop(
                    request,
                    self._prepare_and_run,
                    robot,
                    arrays,
                    options,
                    settings.max_batch,
                    sizing,
                    fill,
                    stop,
                    _batch_split(request),
                    executor=OPENMP_MASTER if in_master else None,
                )
        else:
            states = inputs.prepare_states(robot, arrays, settings.max_batch, fill)
            self._check_size(robot, states, options, sizing)
            large = (
                states.count * robot.nv if work is None else work(robot, states, options)
            ) > INLINE_WORK or states.count * self.quantity.answer_size(
                robot, options, "v" in states.arrays
            ) > INLINE_ANSWER_NUMBERS
            if large:
                async with cancellable(request, self.quantity.name) as stop:
                    result = await off_loop(
                        request,
                        dynamics.run,
                        robot,
                        self.quantity,
                        states,
                        options,
                        stop,
                        _batch_split(request),
                    )
            else:
                result = dynamics.run(robot, self.quantity, states, options)
        request.scope["robodyn"] = {
            "robot": robot.id,
            "quantity": self.quantity.name,
            "batch_size": states.count,
            "compute_seconds": time.perf_counter() - started,
            "large": large,
            "warnings": states.warnings,
        }
        if named:
            keyed = inputs.joint_layout if as_binary else inputs.by_name
            result = keyed(robot, result, self.quantity.joint_answers)
        return result

    def _prepare_and_run(
        self,
        robot: Any,
        arrays: dict[str, Any],
        options: dict[str, Any],
        max_batch: int,
        sizing: "_Sizing",
        fill: str | None = None,
        should_stop: Any = None,
        split: Any = None,
    ) -> tuple[Any, dict[str, Any]]:
        later = dynamics.finite_from_answer(self.quantity, options)
        try:
            states = inputs.prepare_states(robot, arrays, max_batch, fill, later)
            self._check_size(robot, states, options, sizing)
            return states, dynamics.run(robot, self.quantity, states, options, should_stop, split)
        except Exception:
            if later:  # whatever failed: the inputs' own error first, as without `later`
                inputs.prepare_states(robot, arrays, max_batch, fill)
            raise

    def _check_size(
        self, robot: Any, states: Any, options: dict[str, Any], sizing: "_Sizing"
    ) -> None:
        """413 before computing an answer over `ROBODYN_MAX_ANSWER_BYTES`, and 503 when a large
        answer would pass the bytes of answers in flight (`encoding.in_flight`; reserved in
        the request's scope, released once sent). Single states of fixed-size quantities are
        far below both: not checked, the hot path stays as it was."""
        if states.count > 1 or self.quantity.work is not None:
            size = check_answer_size(
                self.quantity,
                robot,
                options,
                "v" in states.arrays,
                states.count,
                sizing.limit,
                sizing.binary,
                sizing.named,
            )
            scope = sizing.connection.scope
            if scope.get("type") == "http" and not scope.get(ANSWER_BYTES):
                in_flight = sizing.connection.app.state.answers_in_flight
                scope[ANSWER_BYTES] = in_flight.reserve(size)

    async def handle(
        self,
        request: HTTPConnection,
        body: bytes | bytearray,
        json_only: bool = False,
        encode_binary: Callable[[dict[str, Any]], bytes] = binary.encode,
    ) -> tuple[bytes | list[bytes], str]:
        """The answer to `body` (JSON or binary, as `Accept` asks; JSON whatever it asks with
        `json_only`) as (content, media type), content in pieces for a large JSON answer;
        domain errors and validation errors are raised for the app's exception handlers.
        `encode_binary` encodes a binary answer (into shared memory for a body that came
        there: `service.api.encoding.shared_bodies`)."""
        check_api_key_for_all(request)
        robot = await served_robot(request.app.state.registry, request.path_params["robot_id"])
        content_type, accept = _media_types(request.scope["headers"])
        if content_type.startswith(binary.BINARY_MEDIA_TYPE):
            arrays, options = self.parse_binary(*binary.decode(body))
        elif content_type and "json" not in content_type.split(";")[0]:
            raise UnsupportedMediaType(
                "send the body as JSON ('Content-Type: application/json') or in the binary "
                f"form ('Content-Type: {binary.BINARY_MEDIA_TYPE}')"
            )
        elif len(body) > ISOLATED_JSON_BYTES:  # parsing holds the GIL: in another process
            arrays, options = await off_loop(
                request, parse_isolated, parse_json_compact, self.quantity.name, body
            )
        elif len(body) > INLINE_BODY_BYTES:
            arrays, options = await off_loop(request, self.parse_json, body)
        else:
            arrays, options = self.parse_json(body)
        as_binary = not json_only and prefers(accept, binary.BINARY_MEDIA_TYPE)
        result = await self.compute(request, robot, arrays, options, as_binary)
        media_type = binary.BINARY_MEDIA_TYPE if as_binary else JSONAnswer.media_type
        header_only = (
            as_binary
            and isinstance(encode_binary, AnswerWriter)
            and encode_binary.header_only(result)
        )
        if request.scope["robodyn"]["large"] and not header_only:
            # In a worker thread (~0.1 s for 10k mass matrices); JSON in pieces, each encoded
            # in one short call, so the event loop gets the GIL in between and the pieces are
            # written as the client reads them.
            encode_large = encode_binary if as_binary else json_pieces
            content: bytes | list[bytes] = await off_loop(request, encode_large, result)
        else:
            content = encode_binary(result) if as_binary else json_bytes(result)
        if request.scope.get(ANSWER_BYTES):  # from the estimate to what is really held
            sent = sum(len(p) for p in content) if isinstance(content, list) else len(content)
            request.app.state.answers_in_flight.resize(request.scope, ANSWER_BYTES, sent)
        return content, media_type

    def json_content(self, request: HTTPConnection, body: bytes | bytearray) -> Produce:
        """The JSON answer to `body` as the progress stream computes it
        (`service.api.progress`: the `Accept` header asks for the stream, not the binary form)."""

        async def produce() -> bytes | list[bytes]:
            content, _ = await self.handle(request, body, json_only=True)
            return content

        return produce

    async def answer(self, request: Request) -> Response | ProgressAnswer:
        """The Starlette endpoint (`service.api.middleware.fast_path` calls `handle` directly)."""
        request.scope["route"] = self.route  # FastAPI's router records only its own routes
        if wants_progress(request.scope):
            return ProgressAnswer(self.json_content(request, await request.body()))
        try:
            content, media_type = await self.handle(request, await request.body())
        finally:
            release_answer_bytes(request.scope, request.app)
        return Response(
            content if isinstance(content, bytes) else b"".join(content),
            media_type=media_type,
            headers=dict(warning_headers(request.scope)),
        )


WARNING_HEADER = "robodyn-warning"


def warning_headers(scope: Any) -> list[tuple[str, str]]:
    """The answer's `Robodyn-Warning` header: what the request's inputs were computed as given
    despite (an angle far outside its joint's range), at most one, in ASCII."""
    warnings = scope.get("robodyn", {}).get("warnings") or ()
    return [(WARNING_HEADER, w.encode("ascii", "replace").decode()) for w in warnings[:1]]


# Built once: an endpoint holds no per-app state (it reads the app from each request).
ENDPOINTS: dict[str, Endpoint] = {name: Endpoint(spec) for name, spec in SPECS.items()}


def parse_json_compact(
    quantity: str, body: bytes | bytearray
) -> tuple[dict[str, Any], dict[str, Any]]:
    """`parse_json` of `quantity`'s endpoint with its joint-space inputs as float64 arrays (as
    the helper process of large bodies sends them back, `service.api.json_bodies`)."""
    arrays, options = ENDPOINTS[quantity].parse_json(body)
    return {name: compact(value) for name, value in arrays.items()}, options


def routes() -> list[Route]:
    """The serving routes, one per quantity."""
    return [endpoint.route for endpoint in ENDPOINTS.values()]


def openapi_routes() -> APIRouter:
    """Routes that only describe the serving routes in the OpenAPI document (never mounted)."""
    router = APIRouter(prefix=PREFIX, tags=["dynamics"])
    for spec in SPECS.values():
        quantity = spec.quantity
        router.add_api_route(
            f"/{{robot_id}}/{quantity.name}",
            _describe(spec),
            methods=["POST"],
            response_model=spec.answer,
            responses=_PROBLEMS,
            summary=quantity.summary,
            name=quantity.name,
            openapi_extra={"x-binary-media-type": binary.BINARY_MEDIA_TYPE},
        )
    return router


def _describe(spec: Spec) -> Any:
    quantity, request_model = spec.quantity, spec.request

    async def endpoint(robot_id: str, body: request_model) -> None:  # type: ignore[valid-type]
        raise NotImplementedError  # documentation only: Endpoint serves the route

    endpoint.__name__ = quantity.name.replace("-", "_")
    endpoint.__doc__ = (
        f"{quantity.compute.__doc__}\n\nThe body may also be sent, and the answer "
        f"asked for, in the binary form ({binary.BINARY_MEDIA_TYPE}, see "
        "docs/binary-format.md)."
    )
    return endpoint
