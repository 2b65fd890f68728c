"""How many child processes of one kind run at once: a bounded number per server process.

Each build (validation and the native parser, `service.registry.build.build_upload`) runs in
its own process and keeps a CPU busy; more of them than CPUs only slow every one down until
they all miss their timeout. `BuildSlots` admits at most `slots` builds at a time (at most the
CPU count); a build waits for a free slot up to `wait_s` seconds, and at most `max_waiting`
builds wait at once (each waiting build holds a worker thread). Beyond either, the upload is
answered 503 `overloaded` with Retry-After: the server's condition, never `invalid_model`.
The build's own timeout starts when it has its slot: waiting is not building.

The derivations of the equations in explicit form (`service.api.workers.equations_cache`) have
slots of their own, another `BuildSlots` (`DERIVATIONS`: its words and settings), so that a
costly derivation never holds a builder an upload waits for.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from service import CPUS
from service.errors import Overloaded

WAITING_PER_SLOT = 4  # builds allowed to wait, per slot


@dataclass(frozen=True)
class SlotNames:
    """The words of a kind of slots' 503 details: what runs in them, and their settings."""

    running: str  # "models are being built"
    worker: str  # "model builder"
    count_setting: str
    wait_setting: str


BUILDS = SlotNames(
    "models are being built",
    "model builder",
    "ROBODYN_MAX_CONCURRENT_BUILDS",
    "ROBODYN_BUILD_QUEUE_TIMEOUT_S",
)
DERIVATIONS = SlotNames(
    "equations are being derived",
    "process deriving equations",
    "ROBODYN_MAX_CONCURRENT_DERIVATIONS",
    "ROBODYN_BUILD_QUEUE_TIMEOUT_S",
)


def build_slot_count(requested: int) -> int:
    """The number of concurrent builds: `requested`, at most the CPU count (0: the CPU
    count)."""
    cpus = max(1, len(CPUS))
    return cpus if requested <= 0 else min(requested, cpus)


class BuildSlots:
    """At most `slots` builds (or what `names` says) at once in this process; see the
    module's description."""

    def __init__(
        self,
        slots: int,
        wait_s: float,
        max_waiting: int | None = None,
        names: SlotNames = BUILDS,
    ) -> None:
        self.slots = slots
        self.wait_s = wait_s
        self.max_waiting = max_waiting if max_waiting is not None else WAITING_PER_SLOT * slots
        self.names = names
        self._free = threading.BoundedSemaphore(slots)
        self._lock = threading.Lock()
        self.waiting = 0
        self.building = 0

    @contextmanager
    def slot(self) -> Iterator[None]:
        """Hold a slot for the duration of the block; `Overloaded` if none frees in time.
        Blocking: call it off the event loop."""
        names = self.names
        with self._lock:
            if self.waiting >= self.max_waiting:
                raise Overloaded(
                    f"{self.building} {names.running} and {self.waiting} are waiting; retry shortly"
                )
            self.waiting += 1
        try:
            acquired = self._free.acquire(timeout=self.wait_s)
        finally:
            with self._lock:
                self.waiting -= 1
        if not acquired:
            raise Overloaded(
                f"no {names.worker} became free within {self.wait_s:g} s "
                f"({self.slots} at a time, {names.count_setting}; "
                f"{names.wait_setting}); retry shortly"
            )
        with self._lock:
            self.building += 1
        try:
            yield
        finally:
            with self._lock:
                self.building -= 1
            self._free.release()
