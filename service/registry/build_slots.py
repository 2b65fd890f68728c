"""How many uploads are built at once: a bounded number of builder processes per server process.

Each build (validation and the native parser, `service.registry.build.build_upload`) runs in
its own process and keeps a CPU busy; more of them than CPUs only slow every one down until
they all miss their timeout. `BuildSlots` admits at most `slots` builds at a time (at most the
CPU count); a build waits for a free slot up to `wait_s` seconds, and at most `max_waiting`
builds wait at once (each waiting build holds a worker thread). Beyond either, the upload is
answered 503 `overloaded` with Retry-After: the server's condition, never `invalid_model`.
The build's own timeout starts when it has its slot: waiting is not building.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

from service import CPUS
from service.errors import Overloaded

WAITING_PER_SLOT = 4  # builds allowed to wait, per slot


def build_slot_count(requested: int) -> int:
    """The number of concurrent builds: `requested`, at most the CPU count (0: the CPU
    count)."""
    cpus = max(1, len(CPUS))
    return cpus if requested <= 0 else min(requested, cpus)


class BuildSlots:
    """At most `slots` builds at once in this process; see the module's description."""

    def __init__(self, slots: int, wait_s: float, max_waiting: int | None = None) -> None:
        self.slots = slots
        self.wait_s = wait_s
        self.max_waiting = max_waiting if max_waiting is not None else WAITING_PER_SLOT * slots
        self._free = threading.BoundedSemaphore(slots)
        self._lock = threading.Lock()
        self.waiting = 0
        self.building = 0

    @contextmanager
    def slot(self) -> Iterator[None]:
        """Hold a build slot for the duration of the block; `Overloaded` if none frees in
        time. Blocking: call it off the event loop."""
        with self._lock:
            if self.waiting >= self.max_waiting:
                raise Overloaded(
                    f"{self.building} models are being built (or their equations "
                    f"derived) and {self.waiting} are waiting; retry shortly"
                )
            self.waiting += 1
        try:
            acquired = self._free.acquire(timeout=self.wait_s)
        finally:
            with self._lock:
                self.waiting -= 1
        if not acquired:
            raise Overloaded(
                f"no model builder became free within {self.wait_s:g} s "
                f"({self.slots} build at a time, ROBODYN_MAX_CONCURRENT_BUILDS; "
                "ROBODYN_BUILD_QUEUE_TIMEOUT_S); retry shortly"
            )
        with self._lock:
            self.building += 1
        try:
            yield
        finally:
            with self._lock:
                self.building -= 1
            self._free.release()
