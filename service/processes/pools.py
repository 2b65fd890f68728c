"""A pool of long-lived spawned helper processes (`concurrent.futures.ProcessPoolExecutor`),
started on first use, limited and watched like every child of this package, and replaced when
one of its processes dies or does not answer in time.

`HelperPool(workers, limits, timeout_s).call(fn, *args)` runs `fn(*args)` in a helper and
returns its result; `fn` and its arguments and result are pickled. Every call waits at most
`timeout_s` seconds for its result (`start_timeout_s` more when the pool has not answered yet:
a fresh helper imports its modules first). A helper that died (e.g. killed over its memory
limit) breaks the pool: `call` raises `BrokenProcessPool`. A helper that does not answer in
time (stopped, hung, starved) is killed with the rest of its pool: `call` raises
`HelperTimedOut`, and the calls waiting on that pool `BrokenProcessPool`. Either way the next
call starts a new pool. `close()` kills the helpers (`tracking.shutdown` closes every pool).
"""

from __future__ import annotations

import contextlib
import threading
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, TypeVar

from service.processes.contexts import launch, spawn_context
from service.processes.limits import ResourceLimits
from service.processes.tracking import disown, own
from service.processes.watchdog import die_with_parent

T = TypeVar("T")


class HelperTimedOut(Exception):
    """A helper gave no answer within its time; its pool was killed."""


def _helper_start(limits: ResourceLimits) -> None:
    """The first code of every helper: the watchdog, then the limits."""
    die_with_parent()
    limits.apply()


class HelperPool:
    """`workers` spawned helpers with `limits`, each call answered within `timeout_s` (see the
    module docstring). Thread-safe."""

    def __init__(
        self,
        workers: int,
        limits: ResourceLimits,
        timeout_s: float = 60.0,
        start_timeout_s: float = 60.0,
    ) -> None:
        self.workers = workers
        self.limits = limits
        self.timeout_s = timeout_s
        self.start_timeout_s = start_timeout_s
        self._lock = threading.Lock()
        self._executor: ProcessPoolExecutor | None = None
        self._answered: ProcessPoolExecutor | None = None  # the pool once it has answered

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
        """`fn(*args)` in a helper; blocking, at most `timeout_s` (`start_timeout_s` more for a
        pool that has not answered yet). Raises what `fn` raises, `BrokenProcessPool` when a
        helper died, `HelperTimedOut` when none answered in time (the pool is then replaced
        for the next call)."""
        executor = self.executor()
        wait_s = self.timeout_s
        if self._answered is not executor:
            wait_s += self.start_timeout_s
        try:
            # submitted from the launcher thread: the helpers are spawned by the submit that
            # finds none idle, and their PDEATHSIG follows the thread that spawned them
            future = launch(executor.submit, fn, *args)
            result = future.result(timeout=wait_s)
        except BrokenProcessPool:
            self._drop(executor, wait=False)
            raise
        except TimeoutError:
            if future.done():  # raised by `fn` itself
                raise
            self._kill(executor)
            raise HelperTimedOut(f"no helper answered within {wait_s:g} s") from None
        self._answered = executor
        return result

    def close(self) -> None:
        """Kill the helpers and reap them (a later `call` starts a new pool)."""
        with self._lock:
            executor = self._executor
        if executor is not None:
            self._kill(executor, wait=True)

    def _kill(self, executor: ProcessPoolExecutor, wait: bool = False) -> None:
        """Kill the pool's helpers and drop it: its waiting calls raise `BrokenProcessPool`."""
        for proc in list((getattr(executor, "_processes", None) or {}).values()):
            with contextlib.suppress(OSError):
                if proc.is_alive():
                    proc.kill()
        self._drop(executor, wait=wait)

    def _drop(self, executor: ProcessPoolExecutor, wait: bool) -> None:
        with self._lock:
            if self._executor is executor:
                self._executor = None
                disown(self)
        executor.shutdown(wait=wait, cancel_futures=True)
