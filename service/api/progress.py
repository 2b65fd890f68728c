"""Progress of long requests: a stream of how far the computation got, then its answer.

A request whose `Accept` names `application/x-ndjson` (`PROGRESS_MEDIA_TYPE`) is answered as
newline-delimited JSON, one object per line:

    {"progress": {"done": 40000, "total": 160001, "unit": "evaluated point",
                  "stage": "inverse dynamics"}}
    ...
    {"answer": <the route's JSON answer, exactly as without progress>}

or, when the computation fails once the stream has begun, a last line
`{"problem": <the problem+json object>}` (its `status` is the one the request would have
answered). Until the first line is sent everything answers as usual: a request refused before
its computation starts (validation, unknown robot, too large an answer, overloaded) gets its
status and a problem+json body, never a stream. Progress lines come at most every
`MIN_INTERVAL_S`, and the last one is repeated every `HEARTBEAT_S` while a stage reports
nothing (a semidefinite program is one long step), so that proxies keep the connection open.

The computation reports through the request's `ProgressChannel` (in the ASGI scope, read by
`progress_channel`): the dynamics loops through their `Cancellation`
(`service.dynamics.stopping`), identification through its worker process. The answer is always
JSON (a progress stream cannot carry the binary form's single file); the request's body may be
in either form.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from typing import Any

import orjson
from starlette.requests import Request
from starlette.types import Receive, Scope, Send

from service.api.encoding.accept import prefers
from service.api.encoding.binary import BINARY_MEDIA_TYPE
from service.api.problems.handlers import handler_for
from service.errors import problem_document

log = logging.getLogger("robodyn.api")

PROGRESS_MEDIA_TYPE = "application/x-ndjson"
SCOPE_KEY = "robodyn.progress"
MIN_INTERVAL_S = 0.2  # seconds between two progress lines (the latest report is sent)
HEARTBEAT_S = 10.0  # the last progress line again after this long without news

Content = bytes | list[bytes]
Produce = Callable[[], Awaitable[Content]]
"""Computes the route's answer: its JSON, whole or in pieces."""


def wants_progress(scope: Scope) -> bool:
    """Whether the request's `Accept` header asks for the progress stream: named with q > 0
    and not below JSON or the binary form (`service.api.encoding.accept`)."""
    for name, value in scope["headers"]:
        if name == b"accept":
            return prefers(value.decode("latin-1"), PROGRESS_MEDIA_TYPE, BINARY_MEDIA_TYPE)
    return False


def progress_channel(scope: Scope) -> ProgressChannel | None:
    """The progress channel of a request answered with progress (None otherwise)."""
    channel = scope.get(SCOPE_KEY)
    return channel if isinstance(channel, ProgressChannel) else None


class ProgressChannel:
    """Where a computation reports how far it got, from any thread; the stream reads the
    latest report (reports in between are coalesced, never queued)."""

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self._loop = loop
        self.latest: dict[str, Any] = {}
        self.changed = asyncio.Event()

    def report(self, done: int, total: int, unit: str, stage: str | None = None) -> None:
        """`done` of `total` units of work are done (`stage`: the step now running)."""
        event: dict[str, Any] = {"done": int(done), "total": int(total), "unit": unit}
        if stage:
            event["stage"] = stage
        self._loop.call_soon_threadsafe(self._set, event)

    def _set(self, event: dict[str, Any]) -> None:
        self.latest = event
        self.changed.set()


class ProgressAnswer:
    """An ASGI app answering `produce()` as a progress stream (see the module docstring).
    A failure before the first line propagates to the caller (which answers it as usual)."""

    def __init__(self, produce: Produce) -> None:
        self.produce = produce

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        channel = ProgressChannel(asyncio.get_running_loop())
        scope[SCOPE_KEY] = channel
        task = asyncio.ensure_future(self.produce())
        try:
            event = await _next_event(channel, task, None)
            if event is None:
                task.result()  # a failure before any progress: answered as usual
            await send(
                {
                    "type": "http.response.start",
                    "status": 200,
                    "headers": [
                        (b"content-type", PROGRESS_MEDIA_TYPE.encode()),
                        (b"cache-control", b"no-store"),
                        (b"x-accel-buffering", b"no"),
                    ],
                }
            )
            last = event
            while event is not None:
                last = event if event is not _HEARTBEAT else last
                await _send_line(send, orjson.dumps({"progress": last}) + b"\n")
                await asyncio.wait({task}, timeout=MIN_INTERVAL_S)  # at most 5 lines a second
                event = await _next_event(channel, task, HEARTBEAT_S)
            await _send_last(send, await _last_line(scope, receive, task))
        finally:
            if not task.done():  # the server is stopping, or the client left mid-send
                task.cancel()


_HEARTBEAT: dict[str, Any] = {}


async def _next_event(
    channel: ProgressChannel, task: asyncio.Future[Any], timeout: float | None
) -> dict[str, Any] | None:
    """The latest progress report not yet sent; `_HEARTBEAT` after `timeout` seconds without
    one; None once the computation is done."""
    if not task.done() and not channel.changed.is_set():
        waiter = asyncio.ensure_future(channel.changed.wait())
        await asyncio.wait({waiter, task}, timeout=timeout, return_when=asyncio.FIRST_COMPLETED)
        waiter.cancel()
    if task.done():
        return None
    if not channel.changed.is_set():
        return _HEARTBEAT
    channel.changed.clear()
    return channel.latest


async def _last_line(scope: Scope, receive: Receive, task: asyncio.Future[Content]) -> list[bytes]:
    """The answer line, or the problem line of the computation's failure."""
    try:
        content = task.result()
    except Exception as exc:
        return [b'{"problem":', await _problem_json(scope, receive, exc), b"}\n"]
    pieces = content if isinstance(content, list) else [content]
    return [b'{"answer":', *pieces, b"}\n"]


async def _problem_json(scope: Scope, receive: Receive, exc: Exception) -> bytes:
    """The problem+json body the app's handlers give `exc` (internal_error for a bug)."""
    handler = handler_for(scope["app"], exc)
    if handler is not None:
        try:
            response = await handler(Request(scope, receive), exc)
            body: bytes = response.body
            return body
        except Exception:  # e.g. the client left: the line is not read anyway
            pass
    log.error("unexpected error on %s %s", scope["method"], scope["path"], exc_info=exc)
    return orjson.dumps(
        problem_document(
            "internal_error",
            "Internal error",
            500,
            "the service failed to answer this request; the failure was logged",
        )
    )


async def _send_line(send: Send, line: bytes) -> None:
    await send({"type": "http.response.body", "body": line, "more_body": True})


async def _send_last(send: Send, pieces: list[bytes]) -> None:
    """The last line, piece by piece (the event loop runs in between)."""
    for i, piece in enumerate(pieces):
        await send({"type": "http.response.body", "body": piece, "more_body": i < len(pieces) - 1})
        await asyncio.sleep(0)
