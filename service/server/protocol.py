"""uvicorn's HTTP/1.1 protocol (httptools), hardened against slow and hostile clients, with each
answer sent in one system call.

What it adds to uvicorn's `HttpToolsProtocol` (settings in `service.settings`, documented in
docs/security.md):

- **Read timeouts.** A request's head (request line and headers) must arrive within
  `ROBODYN_HEADER_TIMEOUT_S` of its first byte (of the connection, for the first request), and
  its body may pause at most `ROBODYN_BODY_TIMEOUT_S` between two reads; otherwise the connection
  is closed. Time during which the server itself stopped reading (back-pressure, pipelining) does
  not count. An answer the client does not read for `ROBODYN_SEND_TIMEOUT_S` drops the connection.
- **A connection cap.** Past `ROBODYN_MAX_CONNECTIONS` open connections per process, a new
  connection evicts the oldest one not busy with a request (idle keep-alive, or a request head
  still incomplete); when every connection is busy with a request, the new one is answered 503
  `overloaded` (problem+json, `Retry-After`) and closed.
- **Honest closes.** An answer that starts before the request's body was read in full (a 413 by
  Content-Length, a 404 before the body, `Expect: 100-continue` answered without the body) says
  `Connection: close`: the unread rest of the body would otherwise be taken for the next request.
  Such closes, and the parser's own 400 (now problem+json), half-close the socket and read what
  the client still sends for up to `LINGER_S` before closing, so the client reads its answer
  instead of a reset.
- **Coalesced writes.** uvicorn writes an answer's status line and headers and its body as two
  `send` calls; the writes one request makes within one step of the event loop are joined here
  and sent together right after that step (`loop.call_soon`): the same bytes, one system call
  (a trivial ASGI app 22,000 → 25,000 requests/s).

It relies on private internals of uvicorn's protocol (pinned in pyproject.toml;
tests/service/server/test_uvicorn_internals.py fails with a clear message if they move).
"""

from __future__ import annotations

import asyncio
import logging
from collections import OrderedDict
from typing import Any

import orjson
from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol, RequestResponseCycle

from service.errors import problem_document
from service.server.limits import (
    CLOSED,
    LINGER_S,
    ConnectionLimits,
    connection_limits,
    problem_answer,
)

log = logging.getLogger("robodyn.connections")


class CoalescedWrites:
    """The socket transport as one request/response cycle sees it: `write`s made in one step of
    the event loop leave in one `write` at the end of that step; `close` closes, or lingers
    (`on_close`) when the request was not read in full; everything else is passed on."""

    __slots__ = ("_loop", "_pending", "_transport", "on_close")

    def __init__(self, transport: asyncio.Transport, loop: asyncio.AbstractEventLoop) -> None:
        self._transport, self._loop = transport, loop
        self._pending: list[bytes] = []
        self.on_close: Any = None

    def write(self, data: bytes) -> None:
        if not self._pending:  # an answer is a few writes (its body one), so nothing piles up
            self._loop.call_soon(self.flush)
        self._pending.append(data)

    def flush(self) -> None:
        pending, self._pending = self._pending, []
        if pending and not self._transport.is_closing():
            if len(pending) == 1:
                self._transport.write(pending[0])
            else:  # uvloop: one writev, no copy of a large body
                self._transport.writelines(pending)

    def close(self) -> None:
        self.flush()
        if self.on_close is not None:
            self.on_close()
        else:
            self._transport.close()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._transport, name)


class GuardedCycle(RequestResponseCycle):
    """uvicorn's request/response cycle, closing the connection (announced) when the answer
    starts before the request's body has been read in full."""

    protocol: HardenedHttpToolsProtocol

    def send(self, message: Any) -> Any:  # (returns uvicorn's coroutine: no extra frame)
        if (
            not self.response_started
            and self.more_body
            and not self.disconnected
            and message["type"] == "http.response.start"
        ):
            self.keep_alive = False  # uvicorn adds `connection: close` and closes after it
            self.transport.on_close = self.protocol.linger_close  # type: ignore[attr-defined]
        return RequestResponseCycle.send(self, message)

    async def send_500_response(self) -> None:
        """uvicorn's last-resort 500 (the application failed before answering), as
        problem+json; the app's own middleware normally answers first."""
        body = orjson.dumps(
            problem_document(
                "internal_error", "Internal error", 500, "the service failed to answer this request"
            )
        )
        await self.send(
            {
                "type": "http.response.start",
                "status": 500,
                "headers": [
                    (b"content-type", b"application/problem+json"),
                    (b"content-length", str(len(body)).encode()),
                    (b"connection", b"close"),
                ],
            }
        )
        await self.send({"type": "http.response.body", "body": body, "more_body": False})


class HardenedHttpToolsProtocol(HttpToolsProtocol):
    """`HttpToolsProtocol` with read timeouts, a connection cap, honest closes and coalesced
    writes (see the module docstring)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.limits = connection_limits()
        self._waiting: str | None = None  # "head" or "body": what the read timer guards
        self._since = 0.0  # start of the head, or the last read of the body (loop time)
        self._busy = False  # a request head has been received and its answer is not done
        self._read_timer: asyncio.TimerHandle | None = None
        self._send_timer: asyncio.TimerHandle | None = None
        # This server's connections that may wait for a request head, oldest first (lingering
        # ones in front): the eviction order at the connection cap, O(1) to keep. Busy ones
        # are skipped (and dropped) when met, and come back when their answer is done.
        idle = getattr(self.server_state, "robodyn_idle", None)
        if idle is None:
            idle = self.server_state.robodyn_idle = OrderedDict()  # type: ignore[attr-defined]
        self._idle: OrderedDict[HardenedHttpToolsProtocol, None] = idle
        self._lingering = False

    # -- connections --------------------------------------------------------------------
    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        full = len(self.connections) >= self.limits.max_connections
        super().connection_made(transport)
        now = self.loop.time()
        if full and not self._evict_one():
            CLOSED["refused"] += 1
            transport.write(
                problem_answer(
                    503,
                    b"Service Unavailable",
                    "overloaded",
                    "Overloaded",
                    f"the server has {self.limits.max_connections} open connections, its limit "
                    "(ROBODYN_MAX_CONNECTIONS); retry shortly",
                    b"retry-after: 1\r\n",
                )
            )
            self.linger_close()
            return
        self._idle[self] = None
        self._waiting, self._since = "head", now
        self._arm_read_timer(self.limits.header_timeout_s)

    def _evict_one(self) -> bool:
        """Close the oldest connection not busy with a request (lingering ones first); False
        when every other connection is busy with a request."""
        while self._idle:
            victim, _ = self._idle.popitem(last=False)
            if victim is self or victim._busy or victim.transport.is_closing():
                continue
            CLOSED["evicted"] += 1
            victim.connections.discard(victim)  # no longer counted, even before it is closed
            victim.transport.close()
            return True
        return False

    def connection_lost(self, exc: Exception | None) -> None:
        for timer in (self._read_timer, self._send_timer):
            if timer is not None:
                timer.cancel()
        self._read_timer = self._send_timer = None
        self._idle.pop(self, None)
        super().connection_lost(exc)

    def linger_close(self) -> None:
        """Close after this answer: half-close now (the client reads the answer, then EOF),
        discard what the client still sends, close on its EOF or after `LINGER_S`."""
        if self._lingering or self.transport.is_closing():
            return
        self._lingering = True
        self._idle[self] = None
        self._idle.move_to_end(self, last=False)  # the first to go at the connection cap
        self._waiting = None
        self.flow.resume_reading()  # keep reading, so the client's sends do not stall
        try:
            if self.transport.can_write_eof():
                self.transport.write_eof()
        except (OSError, RuntimeError):
            self.transport.close()
            return
        self.loop.call_later(LINGER_S, self.transport.close)

    # -- reading ------------------------------------------------------------------------
    def data_received(self, data: bytes) -> None:
        if self._lingering:
            return  # the rest of a request already answered with `connection: close`
        before = self._waiting
        super().data_received(data)
        waiting = self._waiting
        if waiting is not None:  # a request left incomplete by this packet: time it
            if waiting == "body" or before != "head":  # body progress, or a new head began
                self._since = self.loop.time()
            if self._read_timer is None:
                self._arm_read_timer(
                    self.limits.header_timeout_s
                    if waiting == "head"
                    else self.limits.body_timeout_s
                )

    def on_message_begin(self) -> None:
        super().on_message_begin()
        self._waiting = "head"

    def on_headers_complete(self) -> None:
        before = self.cycle
        super().on_headers_complete()  # creates the request's cycle (not for an upgrade)
        cycle = self.cycle
        if cycle is None or cycle is before:  # a WebSocket upgrade: no longer HTTP's business
            self._waiting = None
            self._idle.pop(self, None)
            return
        self._busy = True
        self._waiting = "body"
        # Its ASGI task has not run yet: every write it makes goes through the wrapper.
        cycle.transport = CoalescedWrites(self.transport, self.loop)  # type: ignore[assignment]
        cycle.__class__ = GuardedCycle
        cycle.protocol = self  # type: ignore[attr-defined]

    def on_message_complete(self) -> None:
        self._waiting = None
        super().on_message_complete()

    def on_response_complete(self) -> None:
        if self._lingering:
            self.server_state.total_requests += 1
            return  # no keep-alive timer, no pipelined request: the connection is closing
        super().on_response_complete()
        if not self.pipeline:
            self._busy = False
            if self not in self._idle:
                self._idle[self] = None

    def _arm_read_timer(self, delay: float) -> None:
        self._read_timer = self.loop.call_later(delay, self._read_deadline)

    def _read_deadline(self) -> None:
        self._read_timer = None
        if self._waiting is None or self.transport.is_closing() or self._lingering:
            return
        now = self.loop.time()
        if self.flow.read_paused:  # the server stopped reading, not the client
            self._since = now
        head = self._waiting == "head"
        timeout = self.limits.header_timeout_s if head else self.limits.body_timeout_s
        if now < self._since + timeout:
            self._arm_read_timer(self._since + timeout - now)
            return
        reason = "header_timeout" if head else "body_timeout"
        CLOSED[reason] += 1
        log.debug("closing a connection: %s", reason.replace("_", " "))
        self.transport.close()

    def send_400_response(self, msg: str) -> None:
        """The parser's 400 (malformed request line or headers), as problem+json."""
        CLOSED["bad_request"] += 1
        cycle = self.cycle
        if cycle is not None and not cycle.response_complete:
            # Malformed in its body (e.g. chunk framing): the request is void, its application
            # sees a disconnect and its writes go nowhere.
            cycle.disconnected = True
            cycle.message_event.set()
            if cycle.response_started:  # an answer is under way: no room for another
                self.transport.close()
                return
        self.transport.write(
            problem_answer(
                400,
                b"Bad Request",
                "bad_request",
                "Bad request",
                "the request is not valid HTTP/1.1 (request line or headers)",
            )
        )
        self.linger_close()

    # -- writing ------------------------------------------------------------------------
    def pause_writing(self) -> None:
        super().pause_writing()
        if self._send_timer is None:
            self._send_timer = self.loop.call_later(self.limits.send_timeout_s, self._send_stalled)

    def resume_writing(self) -> None:
        super().resume_writing()
        if self._send_timer is not None:
            self._send_timer.cancel()
            self._send_timer = None

    def _send_stalled(self) -> None:
        self._send_timer = None
        if not self.transport.is_closing():
            CLOSED["send_timeout"] += 1
            log.debug("closing a connection: the client has not read its answer")
            self.transport.abort()


__all__ = [
    "CLOSED",
    "LINGER_S",
    "CoalescedWrites",
    "ConnectionLimits",
    "GuardedCycle",
    "HardenedHttpToolsProtocol",
    "connection_limits",
]
