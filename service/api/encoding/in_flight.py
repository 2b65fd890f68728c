"""The bytes of large answers held by one process, bounded in total.

`ROBODYN_MAX_PENDING_BATCHES` bounds the batches being computed; an answer computed for a
client that does not read it stays in memory until its connection is dropped (up to
`ROBODYN_SEND_TIMEOUT_S` of not reading). So every answer of at least `LARGE_ANSWER_BYTES`
reserves its estimated size (`service.api.encoding.budget.answer_bytes`, an upper bound)
before it is computed, and gives it back once its last byte is handed to the connection (the
server's flow control lets `send` return only when the client has read all but about one
piece) or the request ends otherwise (an error, a disconnect). Past
`ROBODYN_MAX_ANSWER_BYTES_IN_FLIGHT` in total, the request is answered 503 `overloaded` with
`Retry-After`, before anything is computed.
"""

from __future__ import annotations

import threading
from collections.abc import MutableMapping
from typing import Any

from service.errors import Overloaded

LARGE_ANSWER_BYTES = 1 << 20
"""Answers below this size are not counted (the hot path stays free of it); at most
`ROBODYN_MAX_CONNECTIONS` such answers are held at once anyway."""


ANSWER_BYTES = "robodyn_answer_bytes"
"""The ASGI scope's key of the answer bytes its request reserved."""


def release_answer_bytes(scope: MutableMapping[str, Any], app: Any) -> None:
    """Give back the answer bytes the request of `scope` reserved (once)."""
    size = scope.pop(ANSWER_BYTES, 0)
    if size:
        app.state.answers_in_flight.release(size)


class AnswerBytesInFlight:
    """The process-wide total of reserved answer bytes (reserved from worker threads too)."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.held = 0
        self._lock = threading.Lock()

    def reserve(self, size: int) -> int:
        """Reserve `size` bytes and return them (0 for an answer below LARGE_ANSWER_BYTES), or
        raise `Overloaded` when the total would pass the limit. An answer larger than the
        limit alone is admitted when nothing else is held (the answer budget,
        ROBODYN_MAX_ANSWER_BYTES, bounds it)."""
        if size < LARGE_ANSWER_BYTES:
            return 0
        with self._lock:
            if self.held and self.held + size > self.limit:
                held = self.held
                raise Overloaded(
                    f"large answers of {held / 1e6:,.1f} MB are waiting to be read by their "
                    f"clients; this one ({size / 1e6:,.1f} MB) would pass the limit of "
                    f"{self.limit / 1e6:,.1f} MB (ROBODYN_MAX_ANSWER_BYTES_IN_FLIGHT); retry "
                    "shortly",
                    answer_bytes=size,
                    answer_bytes_in_flight=held,
                )
            self.held += size
        return size

    def resize(self, scope: MutableMapping[str, Any], key: str, size: int) -> None:
        """Lower the reservation held under `scope[key]` to `size` bytes, the answer as
        encoded (the estimate is an upper bound: JSON numbers are shorter than the longest)."""
        held = scope.get(key, 0)
        if 0 < size < held:
            self.release(held - size)
            scope[key] = size

    def release(self, size: int) -> None:
        if size:
            with self._lock:
                self.held -= size
