"""The dynamics hot path in front of the framework's routing: `POST /v1/robots/{id}/{quantity}`
goes straight to its `Endpoint`, skipping Starlette's exception middleware, FastAPI's exit
stack and the route table (about 15 µs of a 150 µs single-state answer). It sits inside the
observability and body-limit middleware, so metrics, logs, request ids and limits are the
same; errors are answered by the app's own exception handlers, and unexpected ones propagate
to the server-error middleware exactly as from a routed endpoint. Everything else (other
methods, paths, the WebSocket stream) goes to the app.
"""

from __future__ import annotations

import asyncio
from typing import Any

from starlette.requests import ClientDisconnect, Request
from starlette.types import Message, Receive, Scope, Send

from service.api.encoding.binary import BINARY_MEDIA_TYPE
from service.api.encoding.in_flight import release_answer_bytes
from service.api.encoding.shared_bodies import (
    ANSWER_HEADER,
    AnswerWriter,
    open_shared_body,
    shared_body_header,
)
from service.api.problems.handlers import handler_for
from service.api.progress import ProgressAnswer, wants_progress
from service.api.routes.dynamics import ENDPOINTS, PREFIX, warning_headers
from service.dynamics import answer_arrays
from service.errors import InvalidInput
from service.segments import RequestSegment

_START = PREFIX + "/"
BINARY_PIECE_BYTES = 1 << 20  # a large binary answer is sent in pieces of this size
_MEDIA_TYPES = {
    "application/json": b"application/json",
    BINARY_MEDIA_TYPE: BINARY_MEDIA_TYPE.encode(),
}


class DynamicsFastPath:
    """ASGI middleware: serve the dynamics POST routes directly."""

    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http" and scope["method"] == "POST":
            path: str = scope["path"]
            if path.startswith(_START):
                robot_id, _, quantity = path[len(_START) :].partition("/")
                endpoint = ENDPOINTS.get(quantity)
                if endpoint is not None and robot_id:
                    scope["path_params"] = {"robot_id": robot_id}
                    scope["route"] = endpoint.route  # for the metrics and the access log
                    try:
                        await _answer(endpoint, scope, receive, send)
                    finally:  # sent, failed or abandoned: the answer's bytes are no longer held
                        release_answer_bytes(scope, scope["app"])
                    return
        if scope["type"] == "http" and shared_body_header(scope) is not None:
            await _problem(
                scope,
                receive,
                send,
                InvalidInput("Robodyn-Shared-Body is accepted by the dynamics routes only"),
            )
            return
        await self.app(scope, receive, send)


async def _answer(endpoint: Any, scope: Scope, receive: Receive, send: Send) -> None:
    """Answer one dynamics request: the endpoint's content (as a progress stream when asked
    for, `service.api.progress`), or the app's problem answer. A body in shared memory
    (`service.api.encoding.shared_bodies`) is mapped for the request and let go when it ends,
    however it ends; its binary answer is written there too."""
    segment: RequestSegment | None = None
    try:
        try:
            name = shared_body_header(scope)
            if name is None:
                body: Any = await _body(scope, receive)
            else:
                segment = open_shared_body(scope, name)
                body = segment.body
            if wants_progress(scope):
                await ProgressAnswer(endpoint.json_content(Request(scope, receive), body))(
                    scope, receive, send
                )
                return
            if segment is None:
                content, media_type = await endpoint.handle(Request(scope, receive), body)
            else:  # (a batch computed straight into the answer file: no copy into it)
                with answer_arrays.provided_by(segment.answer_arrays):
                    content, media_type = await endpoint.handle(
                        Request(scope, receive), body, encode_binary=AnswerWriter(segment)
                    )
        except Exception as exc:
            await _problem(scope, receive, send, exc)
            return
        shared = (
            [(ANSWER_HEADER, segment.answer.encode())]
            if segment is not None and segment.answer is not None
            else []
        )
        await _send_content(scope, send, content, media_type, shared)
        if segment is not None:
            # The server sends what a step of the event loop wrote at the end of that step
            # (service/server/protocol.py): ended here, the step lets the answer go before
            # the segment's clean-up and the middleware's bookkeeping (0.1–0.3 ms sooner).
            await asyncio.sleep(0)
    finally:
        if segment is not None:
            segment.end()


async def _problem(scope: Scope, receive: Receive, send: Send, exc: Exception) -> None:
    """The app's problem answer to `exc` (re-raised for the server-error middleware when the
    app has no handler for it: a 500, as for any route)."""
    handler = handler_for(scope["app"], exc)
    if handler is None:
        raise exc
    response = await handler(Request(scope, receive), exc)
    await response(scope, receive, send)


async def _send_content(
    scope: Scope,
    send: Send,
    content: Any,
    media_type: str,
    extra_headers: list[tuple[bytes, bytes]],
) -> None:
    """Send a 200 answer: `content` whole, or in pieces."""
    length = sum(len(p) for p in content) if isinstance(content, list) else len(content)
    await send(
        {
            "type": "http.response.start",
            "status": 200,
            "headers": [
                (b"content-length", str(length).encode()),
                (b"content-type", _MEDIA_TYPES.get(media_type) or media_type.encode()),
                *extra_headers,
                *((k.encode(), v.encode()) for k, v in warning_headers(scope)),
            ],
        }
    )
    if isinstance(content, bytes) and len(content) > BINARY_PIECE_BYTES:
        view = memoryview(content)  # pieces, so that `send` returns once they are read
        content = [
            view[i : i + BINARY_PIECE_BYTES] for i in range(0, len(content), BINARY_PIECE_BYTES)
        ]
    if isinstance(content, list):
        await _send_pieces(send, content)
    else:
        await send({"type": "http.response.body", "body": content})


async def _send_pieces(send: Send, pieces: list[bytes]) -> None:
    """Send a large answer piece by piece, letting the event loop run between pieces: the
    server writes each as the client reads (its flow control pauses `send`), so neither a big
    copy nor a long write blocks the loop, and sent pieces are freed early."""
    last = len(pieces) - 1
    for i in range(len(pieces)):
        piece, pieces[i] = pieces[i], b""
        await send({"type": "http.response.body", "body": piece, "more_body": i < last})
        if i < last:
            await asyncio.sleep(0)


async def _body(scope: Scope, receive: Receive) -> bytes | bytearray:
    """The whole request body (the body-limit middleware outside bounds its size). A body that
    comes in several messages is copied, as it arrives, into one buffer of its Content-Length:
    no join of megabytes at the end, while the client waits."""
    message = await receive()
    chunk = _chunk(message)
    if not message.get("more_body", False):
        return chunk
    length = _content_length(scope)
    if length is None or length < len(chunk):
        chunks = [chunk]
        while message.get("more_body", False):
            message = await receive()
            chunks.append(_chunk(message))
        return b"".join(chunks)
    body = bytearray(length)
    filled = 0
    while True:
        end = filled + len(chunk)
        if end > length:  # more than announced: the server's framing forbids it
            raise InvalidInput(f"the body is longer than its Content-Length {length}")
        body[filled:end] = chunk
        filled = end
        if not message.get("more_body", False):
            return body if filled == length else body[:filled]
        message = await receive()
        chunk = _chunk(message)


def _chunk(message: Message) -> bytes:
    if message["type"] == "http.disconnect":
        raise ClientDisconnect()
    body: bytes = message.get("body", b"")
    return body


def _content_length(scope: Scope) -> int | None:
    for name, value in scope["headers"]:
        if name == b"content-length":
            return int(value) if value.isdigit() else None
    return None
