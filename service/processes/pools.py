"""A pool of long-lived spawned helper processes (`concurrent.futures.ProcessPoolExecutor`),
started on first use, limited and watched like every child of this package, and replaced when
one of its processes dies.

`HelperPool(workers, limits).call(fn, *args)` runs `fn(*args)` in a helper and returns its
result; `fn` and its arguments and result are pickled. A helper that died (e.g. killed over its
memory limit) breaks the pool: `call` raises `BrokenProcessPool` and the next call starts a new
pool. `close()` kills the helpers (`tracking.shutdown` closes every pool).
"""

from __future__ import annotations

import threading
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, TypeVar

from service.processes.contexts import launch, spawn_context
from service.processes.limits import ResourceLimits
from service.processes.tracking import disown, own
from service.processes.watchdog import die_with_parent

T = TypeVar("T")


def _helper_start(limits: ResourceLimits) -> None:
    """The first code of every helper: the watchdog, then the limits."""
    die_with_parent()
    limits.apply()


class HelperPool:
    """`workers` spawned helpers with `limits` (see the module docstring). Thread-safe."""

    def __init__(self, workers: int, limits: ResourceLimits) -> None:
        self.workers = workers
        self.limits = limits
        self._lock = threading.Lock()
        self._executor: ProcessPoolExecutor | None = None

    def executor(self) -> ProcessPoolExecutor:
        """The running pool (a new one if there is none)."""
        with self._lock:
            if self._executor is None:
                self._executor = ProcessPoolExecutor(
                    self.workers,
                    mp_context=spawn_context(),
                    initializer=_helper_start,
                    initargs=(self.limits,),
                )
                own(self)
            return self._executor

    def call(self, fn: Any, *args: Any) -> Any:
        """`fn(*args)` in a helper; blocking. Raises what `fn` raises, or `BrokenProcessPool`
        when a helper died (the pool is then replaced for the next call)."""
        executor = self.executor()
        try:
            # submitted from the launcher thread: the helpers are spawned by the submit that
            # finds none idle, and their PDEATHSIG follows the thread that spawned them
            return launch(executor.submit, fn, *args).result()
        except BrokenProcessPool:
            self._drop(executor, wait=False)
            raise

    def close(self) -> None:
        """Kill the helpers and reap them (a later `call` starts a new pool)."""
        with self._lock:
            executor = self._executor
        if executor is not None:
            for proc in list((getattr(executor, "_processes", None) or {}).values()):
                if proc.is_alive():
                    proc.kill()
            self._drop(executor, wait=True)

    def _drop(self, executor: ProcessPoolExecutor, wait: bool) -> None:
        with self._lock:
            if self._executor is executor:
                self._executor = None
                disown(self)
        executor.shutdown(wait=wait, cancel_futures=True)
