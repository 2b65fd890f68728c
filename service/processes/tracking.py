"""Every child process and pool this package started, and `shutdown`: stop them all.

`shutdown()` is called by the app's lifespan when the server stops and by the test suite's
fixtures. It kills every live child (short-lived or worker), closes every pool, then ends the
launcher thread, the forkserver and multiprocessing's resource tracker: afterwards the calling
process has no child left from this package. Anything started later starts them again, so it is
safe to call at any time (a child killed meanwhile is reported by its caller as a child that
ended without an answer).
"""

from __future__ import annotations

import threading
from multiprocessing.process import BaseProcess
from typing import Protocol

from service.processes.contexts import stop_forkserver, stop_launcher, stop_resource_tracker

JOIN_S = 5.0  # at most this long to reap a killed child


class Closable(Protocol):
    def close(self) -> None: ...


_lock = threading.Lock()
_children: set[BaseProcess] = set()
_pools: set[Closable] = set()


def track(proc: BaseProcess) -> None:
    """Count `proc` among the live children (`end` forgets it)."""
    with _lock:
        _children.add(proc)


def end(proc: BaseProcess) -> None:
    """Kill `proc` if it is still running, reap it, and forget it."""
    try:
        if proc.is_alive():
            proc.kill()
        proc.join(JOIN_S)
    finally:
        with _lock:
            _children.discard(proc)


def own(pool: Closable) -> None:
    """Count `pool` among the running pools (`disown` forgets it)."""
    with _lock:
        _pools.add(pool)


def disown(pool: Closable) -> None:
    with _lock:
        _pools.discard(pool)


def live_children() -> list[BaseProcess]:
    """The children started here and not yet ended."""
    with _lock:
        return list(_children)


def shutdown() -> None:
    """Stop every child, pool and helper process this package started (module docstring)."""
    with _lock:
        pools, children = list(_pools), list(_children)
    for pool in pools:
        pool.close()
    for proc in children:
        end(proc)
    stop_launcher()
    stop_forkserver()
    stop_resource_tracker()
