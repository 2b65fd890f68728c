"""One request and its answer, with no I/O: the `Call` both clients (and streams) send, and
the reading of the server's answer (JSON, the binary form, or a problem+json error).

A `Call` is built by a request builder of `robodyn._calls`; `Client` and `AsyncClient` send it
and hand the response to `read_response`. That is the only difference between them.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import httpx
import numpy as np

from robodyn import binary
from robodyn.answer_memory import AnswerMemory
from robodyn.arrays import check_finite, to_json
from robodyn.errors import APIError, ResponseFormatError, RobodynWarning, error_class
from robodyn.progress import Chunks

T = TypeVar("T")

BINARY_FROM = 4096
"""Requests with this many input numbers or more are sent, and answered, in the binary form
(a safetensors file of raw float64 instead of JSON text: see docs/binary-format.md), unless
the client says otherwise (`Client(binary=...)`)."""
MAX_BINARY_ANSWER = 1 << 32  # bytes; a larger Content-Length is not preallocated
PROGRESS_MEDIA_TYPE = "application/x-ndjson"
"""The media type of the server's progress stream (docs/progress.md): lines of JSON, each
{"progress": {...}}, then {"answer": ...} or {"problem": ...}."""
Body = bytes | list[bytes | memoryview]  # a request body: whole, or in parts


@dataclass(frozen=True)
class Call(Generic[T]):
    """One request to send, and how to read its answer: `read(status, decoded JSON body)`.

    `route` is the server's path template (`/v1/robots/{robot_id}/mass-matrix`), `path` the
    path sent (the robot id quoted in)."""

    method: str
    route: str
    path: str
    read: Callable[[int, Any], T]
    json: Any = None
    accept: frozenset[int] = frozenset()  # statuses handed to `read` (body None), not raised
    arrays: Mapping[str, Any] | None = None  # joint-space inputs (JSON or binary form)
    unchecked: tuple[str, ...] = ()  # arrays checked finite when sent (`check_finite`)
    idempotent: bool = True  # may be sent again after a failure that may follow its sending
    binary_form: bool = True  # False: always JSON (e.g. simulate: its torque schedule is a field)
    chunks: Chunks[T] | None = None  # the same work as consecutive calls (with progress)
    progress_stream: bool = False  # one computation: its progress comes from the server
    shared_memory: bool = True  # a large binary body may go through shared memory (Unix socket)

    @property
    def quantity(self) -> str:
        """The last segment of the route: the quantity a stream message names."""
        return self.route.rsplit("/", 1)[-1]

    def check_finite(self) -> None:
        """The finiteness check of a large batch's arrays (`unchecked`), made when the call is
        sent: `InputError` naming the first non-finite entry. A body through shared memory is
        checked by the server instead, and by this only when the server refuses it."""
        for name in self.unchecked:
            assert self.arrays is not None  # (`unchecked` names arrays)
            check_finite(name, self.arrays[name])

    def binary(self, use_binary: bool | None) -> bool:
        """Whether the joint-space inputs go in the binary form (see `body`)."""
        if (
            self.arrays is None
            or use_binary is False
            or not self.binary_form
            or not all(isinstance(a, np.ndarray) for a in self.arrays.values())
        ):
            return False  # inputs keyed by joint name are JSON objects
        return bool(use_binary) or sum(a.size for a in self.arrays.values()) >= BINARY_FROM

    def json_body(self, fill: str | None = None) -> dict[str, Any]:
        """The JSON object of the request (inputs as nested lists, then the other fields);
        with `fill` when an input is keyed by joint name."""
        body = {**to_json(self.arrays or {}), **(self.json or {})}
        if (
            fill is not None
            and self.arrays is not None
            and not all(isinstance(a, np.ndarray) for a in self.arrays.values())
        ):
            body.setdefault("fill", fill)
        return body

    def body(
        self, use_binary: bool | None, fill: str | None = None
    ) -> tuple[Body | None, str | None]:
        """The body and its media type: bytes, or for the binary form a list of parts
        (`binary.encode_parts`). Joint-space inputs go in the binary form when `use_binary` is
        True, or when it is None and they hold `BINARY_FROM` numbers or more. `fill`: sent
        with inputs keyed by joint name (how the server fills the joints they leave out)."""
        if self.arrays is not None:
            if self.binary(use_binary):  # (checked finite when it is known how it is sent)
                return binary.encode_parts(self.arrays, self.json), binary.MEDIA_TYPE
            self.check_finite()
            return encode(self.json_body(fill)), "application/json"
        if self.json is not None:
            return encode(self.json), "application/json"
        return None, None


def binary_length(response: httpx.Response) -> int | None:
    """The byte length of a successful binary answer sent as is (Content-Length, no content
    coding): such an answer is read into one preallocated buffer (`Receiver`) rather
    than through httpx's chunk list. None for every other answer."""
    headers = response.headers
    if (
        200 <= response.status_code <= 299
        and headers.get("content-type", "").startswith(binary.MEDIA_TYPE)
        and headers.get("content-encoding", "identity") == "identity"
    ):
        length = headers.get("content-length", "")
        if length.isdigit() and 0 < int(length) <= MAX_BINARY_ANSWER:
            return int(length)
    return None


class Receiver:
    """Collects a body of known length, chunk by chunk, into one preallocated buffer.

    A large answer (23 MB for 2,000 Talos mass matrices) read by httpx as a list of 64 kB
    chunks and then joined was copied twice more; written straight into its final buffer (from
    `memory`: reused once the arrays of an earlier answer are gone) it is copied once, and
    `binary.decode` makes its arrays views of that buffer."""

    def __init__(self, response: httpx.Response, length: int, memory: AnswerMemory) -> None:
        self._status = response.status_code
        self._view = memory.take(length)
        self._filled = 0

    def add(self, chunk: bytes) -> None:
        end = self._filled + len(chunk)
        if end > len(self._view):
            raise ResponseFormatError(
                f"the answer is longer than its Content-Length {len(self._view)}",
                status=self._status,
            )
        self._view[self._filled : end] = chunk
        self._filled = end

    def finish(self) -> memoryview:
        if self._filled != len(self._view):
            raise ResponseFormatError(
                f"the answer ended after {self._filled} of its {len(self._view)} bytes",
                status=self._status,
            )
        return self._view


WARNING_HEADER = "robodyn-warning"  # what the server computed as given but finds doubtful


def read_response(
    call: Call[T], response: httpx.Response, received: bytearray | memoryview | None = None
) -> T:
    """The result of `call` from its answer; an `APIError` subclass for an error status.
    `received` is the body already read into a buffer (see `binary_length`), if it was."""
    status = response.status_code
    if status in call.accept:
        return call.read(status, None)
    if not 200 <= status <= 299:
        raise api_error(response)
    warning = response.headers.get(WARNING_HEADER)
    if warning:
        warnings.warn(f"{call.method} {call.path}: {warning}", RobodynWarning, stacklevel=4)
    body: Any = None
    if received is not None or response.content:
        is_binary = response.headers.get("content-type", "").startswith(binary.MEDIA_TYPE)
        try:
            if received is not None:
                body = binary.decode(received)
            else:
                body = binary.decode(response.content) if is_binary else response.json()
        except ValueError:
            form = "in the binary form it claims" if is_binary else "JSON"
            start = (
                bytes(received[:1000]).decode("utf-8", "replace")
                if received is not None
                else response.text[:1000]
            )
            raise ResponseFormatError(
                f"{call.method} {call.path} answered {status} with a body that is not {form}",
                status=status,
                body=start,
            ) from None
    return _read(call, status, body)


def _read(call: Call[T], status: int, body: Any) -> T:
    try:
        return call.read(status, body)
    except (KeyError, ValueError, TypeError, IndexError) as exc:
        raise ResponseFormatError(
            f"{call.method} {call.path} answered {status} with an unexpected body: {exc!s}",
            status=status,
            body=body,
        ) from exc


def is_progress_stream(response: httpx.Response) -> bool:
    """Whether a response is the server's progress stream (a success, lines of JSON)."""
    return 200 <= response.status_code <= 299 and response.headers.get(
        "content-type", ""
    ).startswith(PROGRESS_MEDIA_TYPE)


class ProgressLines(Generic[T]):
    """Reads the lines of a progress stream: `feed(line)` reports progress lines to `report`
    (called with each {"done", "total", "unit", "stage"} object), keeps the answer, and raises
    the `APIError` of a problem line; `result()` is the answer read by the call."""

    def __init__(self, call: Call[T], report: Callable[[Mapping[str, Any]], object]) -> None:
        self.call, self.report = call, report
        self._answer: Any = None
        self._done = False

    def feed(self, line: str) -> None:
        if not line.strip():
            return
        try:
            message = json.loads(line)
            key = next(iter(message))
        except (ValueError, TypeError, StopIteration):
            raise ResponseFormatError(
                f"{self.call.method} {self.call.path}: a line of its "
                "progress stream is not a JSON object",
                status=200,
                body=line[:1000],
            ) from None
        if key == "progress":
            self.report(message["progress"])
        elif key == "answer":
            self._answer, self._done = message["answer"], True
        elif key == "problem":
            raise problem_error(message["problem"], None, None)

    def result(self) -> T:
        if not self._done:
            raise ResponseFormatError(
                f"{self.call.method} {self.call.path}: its progress stream ended before the answer",
                status=200,
            )
        return _read(self.call, 200, self._answer)


def api_error(response: httpx.Response) -> APIError:
    """The exception for an error answer (problem+json, or any other body)."""
    body: Any
    try:
        body = response.json()
    except ValueError:
        body = response.text[:1000]
    retry_after: float | None
    try:
        retry_after = float(response.headers["retry-after"])
    except (KeyError, ValueError):
        retry_after = None
    return problem_error(body, response, retry_after)


def problem_error(
    body: Any, response: httpx.Response | None, retry_after: float | None
) -> APIError:
    """The exception for a problem (problem+json, or any other body) of an error answer (its
    status from `response`, else from the problem's `status`)."""
    problem = body if isinstance(body, dict) else {}
    status = (
        response.status_code
        if response is not None
        else int(problem["status"])
        if isinstance(problem.get("status"), int)
        else 500
    )
    reason = response.reason_phrase if response is not None else None
    code = problem.get("code") if isinstance(problem.get("code"), str) else None
    title = str(problem.get("title") or reason or f"HTTP {status}")
    detail = str(problem.get("detail") or (body if isinstance(body, str) and body else title))
    return error_class(status, code)(status, code, title, detail, body, retry_after)


def encode(body: Any) -> bytes:
    """The JSON bytes of a request body (inputs were checked finite before)."""
    return json.dumps(body, allow_nan=False, separators=(",", ":")).encode()
