"""Stopping long computations: a caller's `should_stop()` asked every few milliseconds.

A rollout (`simulate`) or a batch loop over states (the contact quantities) calls
`Stopper.poll` once per step or state; the stopper asks `should_stop` at most every
POLL_S seconds of computing (a clock read otherwise, about 50 ns), and a true answer raises
`ComputationStopped` at once. The POLL_S run from the end of one ask (and its progress
report) to the next clock read, so two asks are always at least POLL_S apart. The caller
decides why to stop: the client went away, or the request's deadline passed. Without
`should_stop` nothing is asked.

Each time `should_stop` is asked, the computing thread also hands the GIL over (`hand_over`):
a loop whose steps call into NumPy's BLAS or LAPACK (a least-squares solve per state) releases
the GIL and takes it back hundreds of times a millisecond, and CPython's GIL then starves a
waiting thread — the event loop — for as long as the loop runs (the convoy effect: /health/live
waited 0.7 s beside a 20,000-state contact batch). `time.sleep(0)` every POLL_S lets it in.

A batch of Pinocchio's OpenMP algorithms, which holds the GIL for each whole native call, asks
`may_hold` whether it may compute the rest of the batch in one call (`service.dynamics.parallel`).

Progress: a `should_stop` that also has a `report(done, total, unit, stage)` method (the API's
`Cancellation`, which forwards to a request's progress stream) hears how far the computation
got, at the same moments it is asked, when the stopper knows the `total`; `report_progress`
does the same for loops without a stopper.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from service.errors import ComputationStopped

POLL_S = 0.002  # how often `should_stop` is asked, in seconds of computing

ShouldStop = Callable[[], bool]


def hand_over() -> None:
    """Let a thread waiting for the GIL (the event loop) take it (see the module docstring)."""
    time.sleep(0)


def may_hold(should_stop: Any, seconds: float) -> bool:
    """Whether a computation may go on for about `seconds` without asking `should_stop` or
    handing the GIL over: when `should_stop` has a `may_hold(seconds)` method (the API's
    `Cancellation`: the serving process has nothing else to do and the deadline is far) and
    it says so; never without one."""
    ask = getattr(should_stop, "may_hold", None)
    return bool(ask is not None and ask(seconds))


def report_progress(
    should_stop: Any, done: int, total: int, unit: str, stage: str | None = None
) -> None:
    """Tell `should_stop` (when it listens: a `report` method) that `done` of `total` units
    of work are done."""
    report = getattr(should_stop, "report", None)
    if report is not None:
        report(done, total, unit, stage)


class Stopper:
    """Ask `should_stop` at most every POLL_S seconds; raise `ComputationStopped` naming
    `what` was computed and how far it got (`where` and the `unit` number k). With `total`
    (the units of the whole computation), also report progress: `offset` + k of `total`."""

    __slots__ = (
        "next",
        "offset",
        "report",
        "should_stop",
        "stage",
        "total",
        "unit",
        "what",
        "where",
    )

    def __init__(
        self,
        should_stop: ShouldStop | None,
        what: str,
        unit: str,
        total: int | None = None,
        stage: str | None = None,
    ) -> None:
        self.should_stop = should_stop
        self.what, self.unit = what, unit
        self.where = ""  # e.g. "state 3: " in a batch of rollouts
        self.next = time.monotonic() + POLL_S
        self.total, self.stage, self.offset = total, stage, 0
        self.report = getattr(should_stop, "report", None) if total else None

    def poll(self, k: int) -> None:
        """Called at step (or state) k."""
        if self.should_stop is None:
            return
        if time.monotonic() < self.next:
            return
        hand_over()
        if self.should_stop():
            raise ComputationStopped(
                f"{self.what}: {self.where}stopped at {self.unit} {k} before the end (the "
                "client went away or the request's deadline passed)"
            )
        if self.report is not None:
            self.report(self.offset + k, self.total, self.unit, self.stage)
        # The interval counts from the end of this ask (not from the clock read above): the
        # hand-over and `should_stop` take a variable time, and two asks are then always at
        # least POLL_S apart.
        self.next = time.monotonic() + POLL_S
