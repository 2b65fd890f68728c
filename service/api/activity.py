"""Whether a serving process has other requests to attend to while it computes a large batch.

A batch computed by Pinocchio's OpenMP algorithms holds the GIL for as long as each native call
lasts, so it is cut into calls of about a millisecond whenever another request may be waiting
(`service.dynamics.parallel`). When nothing else is going on, one call over the rest of the
batch is faster (no fork and join of the OpenMP team per millisecond: on a loaded machine each
of those waits for both cores). `Activity` keeps what that decision needs: how many HTTP
requests and stream messages are being answered, and when the last one that was not itself a
large batch ended. The process is `quiet` when the asking batch's request is the only one in
flight and no other request ended within `QUIET_S`: a client sending requests one after the
other keeps the batch in short calls, while a lone co-located client's batch runs whole.
"""

from __future__ import annotations

import time

QUIET_S = 0.25
"""Seconds since the last other request (not a large batch) ended before a process counts
as quiet: longer than the pause of a client that sends its requests in a loop."""


class Activity:
    """Requests in flight in this process and the end of the last small one (event loop
    only: no lock; worker threads only read)."""

    __slots__ = ("in_flight", "last_small_end")

    def __init__(self) -> None:
        self.in_flight = 0
        self.last_small_end = 0.0  # time.monotonic() of the end of the last small request

    def started(self) -> None:
        """A request (or a stream message) is being answered."""
        self.in_flight += 1

    def ended(self, large: bool) -> None:
        """A request ended; `large`: it was a batch computed off the event loop (whose
        client does not wait for milliseconds)."""
        self.in_flight -= 1
        if not large:
            self.last_small_end = time.monotonic()

    def quiet(self) -> bool:
        """True when the asking request is the only one in flight and no small request ended
        within the last `QUIET_S` seconds."""
        return self.in_flight <= 1 and time.monotonic() - self.last_small_end > QUIET_S
