"""The multiprocessing contexts of robodyn's children, and the thread that starts spawned ones.

- `forkserver_context(preload)`: one forkserver per serving process (multiprocessing's own),
  started by the first child that needs it, with `preload` imported once there, so each forked
  child starts in milliseconds with those modules loaded. Every caller's modules are added to
  the list; what is listed when the forkserver starts is preloaded (a module listed later is
  imported by each child instead).
- `spawn_context()`: a fresh interpreter for each child (the long-lived workers, which import
  their own modules once and serve for the life of the server).
- `launch(fn, ...)`: runs `fn` in the launcher, one long-lived thread that starts every spawned
  child: a child's PDEATHSIG (`watchdog`) fires when the thread that started it ends, so it
  must not be one of the server's short-lived worker threads.

`stop_forkserver`, `stop_launcher` and `stop_resource_tracker` end them (multiprocessing's
resource tracker is a process of its own, started with the first non-forked child); used by
`tracking.shutdown` once every child is gone.
"""

from __future__ import annotations

import multiprocessing as mp
import threading
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from multiprocessing import forkserver, resource_tracker
from multiprocessing.context import ForkServerContext, SpawnContext
from typing import Any, TypeVar

T = TypeVar("T")

_lock = threading.Lock()
_preload: list[str] = []
_launcher: ThreadPoolExecutor | None = None


def forkserver_context(preload: Iterable[str] = ()) -> ForkServerContext:
    """The forkserver context, with `preload` added to the modules the forkserver imports
    when it starts."""
    context = mp.get_context("forkserver")
    with _lock:
        added = [name for name in preload if name not in _preload]
        if added:
            _preload.extend(added)
            context.set_forkserver_preload(list(_preload))
    return context


def spawn_context() -> SpawnContext:
    """The spawn context: each child a fresh interpreter."""
    return mp.get_context("spawn")


def launch(fn: Callable[..., T], *args: Any) -> T:
    """`fn(*args)` run in the launcher thread (started on first use); blocking."""
    global _launcher
    while True:
        with _lock:
            if _launcher is None:
                _launcher = ThreadPoolExecutor(1, thread_name_prefix="robodyn-launcher")
            launcher = _launcher
        try:
            future = launcher.submit(fn, *args)
        except RuntimeError:  # shut down by `stop_launcher` meanwhile: a new one
            with _lock:
                if _launcher is launcher:
                    _launcher = None
            continue
        return future.result()


def stop_launcher() -> None:
    """End the launcher thread (a later `launch` starts a new one)."""
    global _launcher
    with _lock:
        launcher, _launcher = _launcher, None
    if launcher is not None:
        launcher.shutdown(wait=True)


def stop_forkserver() -> None:
    """End the forkserver, if one runs (a later forked child starts a new one). Its children
    are killed by their PDEATHSIG as it ends."""
    stop = getattr(forkserver._forkserver, "_stop", None)
    if stop is not None:
        stop()


def stop_resource_tracker() -> None:
    """End multiprocessing's resource tracker process, if one runs (it is started again by
    the next child or named semaphore that needs it)."""
    stop = getattr(resource_tracker._resource_tracker, "_stop", None)
    if stop is not None:
        stop()
