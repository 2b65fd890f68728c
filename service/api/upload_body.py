"""Reading an upload's JSON body (`POST /v1/robots`): inline when small, in a child process
when large.

Decoding a JSON body (`json.loads`) and validating it (pydantic) are C calls that hold the GIL
for their whole duration: a 64 MB body with 5 million unknown members takes ~5-9 s, and a worker
thread would not help, since the event loop needs the GIL too. So a body of more than
`INLINE_UPLOAD_BYTES` is decoded and validated by `UploadRequest` in a short-lived child forked
from the builders' forkserver (`service.processes.run_child`), one at a time per build slot
(`service.registry.build_slots`), limited like a builder (nice 10, CPU time, address space
`MEMORY_MB`); the serving process only waits for the answer in a worker thread. The child
answers with the validated `UploadRequest` (pickled: no validation again) or the errors, already
bounded by `service.api.problems.validation_errors.pydantic_errors`; the serving process turns
them into the same problem answers as FastAPI's own body parsing would (`read_upload` is that
parsing, done the same way inline and in the child).
"""

from __future__ import annotations

import email.message
import json
import os
from typing import Any

import orjson
from fastapi.exceptions import RequestValidationError
from pydantic import ValidationError

from service.api.problems.validation_errors import pydantic_errors
from service.api.schemas.robots import UploadRequest
from service.errors import InvalidInput, Overloaded
from service.processes import (
    ChildDied,
    ChildNotStarted,
    ChildTimedOut,
    ResourceLimits,
    killed_detail,
    run_child,
)
from service.registry.build_process import FORKSERVER_PRELOAD
from service.registry.build_slots import BuildSlots

INLINE_UPLOAD_BYTES = 1024 * 1024
"""Upload bodies up to this size are decoded and validated in the serving process (~10 ms)."""
MEMORY_MB = 2048  # address space of the child: 5 M members in 64 MB decode to ~800 MB
_UNPARSABLE = {
    RecursionError: "the JSON body is nested too deeply to be read",
    UnicodeDecodeError: "the JSON body is not UTF-8 text",
}

Outcome = tuple[str, Any]
"""("ok", UploadRequest), ("invalid", pydantic error dicts located under "body") or
("unparsable", the reason in words)."""


def is_json(content_type: str | None) -> bool:
    """Whether FastAPI reads a body with this Content-Type as JSON (the app is not strict
    about a missing one): application/json, application/*+json or none."""
    if not content_type:
        return True
    message = email.message.Message()
    message["content-type"] = content_type
    subtype = message.get_content_subtype()
    return message.get_content_maintype() == "application" and (
        subtype == "json" or subtype.endswith("+json")
    )


def read_upload(body: bytes, content_type: str | None, keep: list[Any] | None = None) -> Outcome:
    """The upload `body` decoded and validated as FastAPI does for a body parameter (the same
    error objects, bounded by `pydantic_errors`): work proportional to the body's size. With
    `keep`, the decoded body is decoded by orjson (2-3 times faster than `json`; a body it
    refuses is read again by `json`, for the same answer) and appended to `keep` (so a child
    process exits without freeing it object by object)."""
    if not body:
        return "invalid", [{"type": "missing", "loc": ("body",), "msg": "Field required"}]
    if not is_json(content_type):  # validated as bytes: refused (415 by the handler)
        return "invalid", [
            {
                "type": "model_attributes_type",
                "loc": ("body",),
                "msg": "Input should be a valid dictionary or object to extract fields from",
            }
        ]
    try:
        data = _decode(body, keep is not None)
    except json.JSONDecodeError as exc:
        return "invalid", [
            {
                "type": "json_invalid",
                "loc": ("body", exc.pos),
                "msg": "JSON decode error",
                "ctx": {"error": exc.msg},
            }
        ]
    except Exception as exc:
        return "unparsable", next(
            (text for kind, text in _UNPARSABLE.items() if isinstance(exc, kind)),
            "the body is not valid JSON",
        )
    if keep is not None:
        keep.append(data)
    try:
        return "ok", UploadRequest.model_validate(data)
    except ValidationError as exc:
        return "invalid", [
            {**e, "loc": ("body", *e["loc"])}
            for e in pydantic_errors(exc, UploadRequest, lambda: data)
        ]


def _decode(body: bytes, fast: bool) -> Any:
    if fast:
        try:
            return orjson.loads(body)
        except orjson.JSONDecodeError:
            pass  # NaN, lone surrogates, ...: `json` reads them, or gives its own error
    return json.loads(body)


def upload_request(outcome: Outcome) -> UploadRequest:
    """The validated request of `read_upload`'s outcome, or the error the app's handlers
    answer (422 validation_error, or 415 for a body that is not JSON)."""
    kind, value = outcome
    if kind == "ok":
        assert isinstance(value, UploadRequest)
        return value
    if kind == "invalid":
        raise RequestValidationError(value)
    raise InvalidInput(f"body: {value}")


def _child_read(conn: Any, content_type: str | None, memory_mb: int) -> None:
    """The child (its limits already set): receives the body, answers `read_upload`'s
    outcome."""
    try:
        body = conn.recv_bytes()
        kept: list[Any] = []
        try:
            outcome = read_upload(body, content_type, kept)
        except MemoryError:
            kept.clear()
            outcome = ("unparsable", f"reading the JSON body needed more than {memory_mb} MB")
        conn.send(outcome)
    finally:
        conn.close()
    os._exit(0)  # what was decoded is not freed piece by piece (~1 s for 5 M members)


def read_upload_isolated(
    body: bytes,
    content_type: str | None,
    slots: BuildSlots,
    timeout_s: float,
    cpu_s: int,
    memory_mb: int = MEMORY_MB,
) -> Outcome:
    """`read_upload` in a resource-limited child holding a build slot; blocking (call it off
    the event loop). `Overloaded` when no slot or process is free, when the child timed out
    having been starved of CPU, or when it was killed from outside (SIGKILL not of its limits,
    e.g. the OOM killer); a child past its limits is `InvalidInput` naming them."""
    with slots.slot():
        try:
            outcome: Outcome = run_child(
                _child_read,
                (content_type, memory_mb),
                timeout_s=timeout_s,
                limits=ResourceLimits(memory_mb=memory_mb, cpu_s=cpu_s),
                preload=FORKSERVER_PRELOAD,
                send_bytes=body,
            )
        except ChildNotStarted:
            raise Overloaded("could not start a process to read the body; retry shortly") from None
        except ChildTimedOut as exc:
            if exc.starved(timeout_s):
                raise Overloaded(
                    "reading the body got too little CPU time: the server is "
                    "too busy right now; retry shortly"
                ) from None
            raise InvalidInput(f"body: reading it took longer than {timeout_s:g} s") from None
        except ChildDied as exc:
            if exc.killed_from_outside(cpu_s):
                detail = killed_detail("the process reading the body", exc.exitcode)
                raise Overloaded(detail) from None
            raise InvalidInput(
                f"body: the process reading it ended without an answer (its "
                f"limits: {cpu_s} s of CPU, {memory_mb} MB)"
            ) from None
    return outcome
