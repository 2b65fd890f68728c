"""Stopping long computations: a caller's `should_stop()` asked every few milliseconds.

A rollout (`simulate`) or a batch loop over states (the contact quantities) calls
`Stopper.poll` once per step or state; the stopper asks `should_stop` at most every
POLL_S seconds of computing (a clock read otherwise, about 50 ns), and a true answer raises
`ComputationStopped`. The caller decides why: the client went away, or the request's
deadline passed. Without `should_stop` nothing is asked.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from service.errors import ComputationStopped

POLL_S = 0.002  # how often `should_stop` is asked, in seconds of computing

ShouldStop = Callable[[], bool]


class Stopper:
    """Ask `should_stop` at most every POLL_S seconds; raise `ComputationStopped` naming
    `what` was computed and how far it got (`where` and the `unit` number k)."""

    __slots__ = ("next", "should_stop", "unit", "what", "where")

    def __init__(self, should_stop: ShouldStop | None, what: str, unit: str) -> None:
        self.should_stop = should_stop
        self.what, self.unit = what, unit
        self.where = ""  # e.g. "state 3: " in a batch of rollouts
        self.next = time.monotonic() + POLL_S

    def poll(self, k: int) -> None:
        """Called at step (or state) k."""
        if self.should_stop is None:
            return
        now = time.monotonic()
        if now < self.next:
            return
        self.next = now + POLL_S
        if self.should_stop():
            raise ComputationStopped(
                f"{self.what}: {self.where}stopped at {self.unit} {k} before the end (the "
                "client went away or the request's deadline passed)")
