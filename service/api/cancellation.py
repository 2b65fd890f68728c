"""Stopping a request's long computation: its deadline, and its client going away.

A computation run off the event loop (a large batch, a simulation, a contact batch) gets a
`Cancellation` as its `should_stop` (`service.dynamics.stopping`): rollouts and contact batches
ask it every few milliseconds, between steps or states, and other batches between chunks of
states (`service.dynamics.run`). It stops the computation when

- the request's deadline passed: `ROBODYN_REQUEST_DEADLINE_S` seconds after the computation
  started (its first question; time waiting for a worker is not counted): `DeadlineExceeded`,
  504 `deadline_exceeded` (not retried by clients: the same request would stop again), or
- the client closed its connection: `watch_disconnect` waits on the request's ASGI `receive`
  (whose next message, once the body is read, is `http.disconnect`) while it computes:
  `ComputationStopped` (503 `overloaded`, an answer nobody reads).

`STOPPED` counts the stops by reason, exported as `robodyn_computations_stopped_total`.

`may_hold(seconds)` tells a batch of Pinocchio's OpenMP algorithms whether it may compute for
`seconds` without asking again (`service.dynamics.parallel`): only when the serving process
has nothing else to serve (`service.api.activity`), the client is there, and the deadline is at
least twice that far (and never past `MAX_HOLD_S`).

A request answered with progress (`service.api.progress`) has a progress channel in its scope;
its `Cancellation` forwards what the computation reports (`report`) to it.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from service.api.activity import Activity
from service.api.progress import progress_channel
from service.errors import ComputationStopped, DeadlineExceeded

STOPPED: dict[str, int] = {"deadline": 0, "disconnect": 0}
MAX_HOLD_S = 0.25
"""The longest a computation may go on without asking (`Cancellation.may_hold`), in seconds:
a client that goes away is noticed within about this, and a request that comes in while it
runs (a health probe after a quiet spell) waits at most about this."""


class Cancellation:
    """`should_stop` of one request: raises `ComputationStopped` naming why, else False."""

    __slots__ = ("activity", "deadline", "deadline_s", "disconnected", "progress", "quantity")

    def __init__(
        self,
        quantity: str,
        deadline_s: float,
        progress: Any = None,
        activity: Activity | None = None,
    ) -> None:
        self.quantity, self.deadline_s = quantity, deadline_s
        self.deadline = 0.0  # from the first question: when the computation started
        self.disconnected = False  # set on the event loop, read by the worker thread
        self.progress = progress  # the request's `ProgressChannel`, or None
        self.activity = activity  # the serving process's requests in flight, or None

    def may_hold(self, seconds: float) -> bool:
        """Whether the computation may go on for `seconds` without asking again: the
        process is quiet (`service.api.activity`; never when unknown), the client has not
        gone, and at least twice `seconds` are left before the deadline."""
        return (
            self.activity is not None
            and not self.disconnected
            and seconds <= MAX_HOLD_S
            and self.activity.quiet()
            and (not self.deadline or time.monotonic() + 2 * seconds < self.deadline)
        )

    def report(self, done: int, total: int, unit: str, stage: str | None = None) -> None:
        """How far the computation got (`service.dynamics.stopping.report_progress`)."""
        if self.progress is not None:
            self.progress.report(done, total, unit, stage)

    def __call__(self) -> bool:
        if not self.deadline:
            self.deadline = time.monotonic() + self.deadline_s
        if self.disconnected:
            STOPPED["disconnect"] += 1
            raise ComputationStopped(f"{self.quantity}: stopped, the client closed the connection")
        if time.monotonic() > self.deadline:
            STOPPED["deadline"] += 1
            raise DeadlineExceeded(
                f"{self.quantity}: stopped after {self.deadline_s:g} s of computing, the "
                "request deadline (ROBODYN_REQUEST_DEADLINE_S); send fewer states or steps "
                "per request",
                deadline_s=self.deadline_s,
            )
        return False


async def watch_disconnect(receive: Any, cancellation: Cancellation) -> None:
    """Mark `cancellation` when the client disconnects (the request's body is read already:
    the next ASGI message is the disconnect)."""
    while True:
        message = await receive()
        if message.get("type") == "http.disconnect":
            cancellation.disconnected = True
            return


@asynccontextmanager
async def cancellable(connection: Any, quantity: str) -> AsyncIterator[Cancellation]:
    """A `Cancellation` for the computation run inside, with its deadline from the settings,
    watching for the client's disconnect on HTTP requests (WebSocket messages: the deadline
    only)."""
    cancellation = Cancellation(
        quantity,
        connection.app.state.settings.request_deadline_s,
        progress_channel(connection.scope),
        getattr(connection.app.state, "activity", None),
    )
    receive = getattr(connection, "_receive", None)
    watcher = None
    if connection.scope.get("type") == "http" and receive is not None:
        watcher = asyncio.ensure_future(watch_disconnect(receive, cancellation))
    try:
        yield cancellation
    finally:
        if watcher is not None:
            watcher.cancel()
