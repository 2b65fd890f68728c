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
`tracking.shutdown` once every child is gone. Each waits for its process at most `STOP_S`
seconds, then kills it (a stopped or hung process never holds the server's exit).
`kill_forkserver` kills a forkserver that does not answer (`children`): the next forked child
starts a new one.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import signal
import threading
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from multiprocessing import forkserver, resource_tracker
from multiprocessing.context import ForkServerContext, SpawnContext
from typing import Any, TypeVar

T = TypeVar("T")

STOP_S = 5.0  # a process asked to stop is killed after this long

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


def _kill(pid: int | None) -> None:
    if pid:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)


def _stop_within(owner: Any, pid_name: str) -> None:
    """`owner._stop()` (multiprocessing's own: ask its process to end, then wait for it), with
    the process killed if it has not ended after `STOP_S` seconds."""
    stop = getattr(owner, "_stop", None)
    pid = getattr(owner, pid_name, None)
    if stop is None or pid is None:
        return  # none runs, or it is not this process's (a spawned server's inherited one)
    killer = threading.Timer(STOP_S, _kill, (pid,))
    killer.daemon = True
    killer.start()
    try:
        stop()
    finally:
        killer.cancel()


def forkserver_running() -> bool:
    """Whether this process has started a forkserver that has not ended (a zombie counts as
    ended)."""
    pid = getattr(forkserver._forkserver, "_forkserver_pid", None)
    if pid is None:
        return False
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            return fh.read().rsplit(b")", 1)[1].split()[0] not in (b"Z", b"X")
    except (OSError, IndexError):
        return False


def kill_forkserver() -> None:
    """Kill the forkserver (one that does not answer: stopped or hung), if one runs; a child it
    was starting is not started, its children die with it (their PDEATHSIG), and the next
    forked child starts a new forkserver."""
    _kill(getattr(forkserver._forkserver, "_forkserver_pid", None))


def stop_forkserver() -> None:
    """End the forkserver, if one runs (a later forked child starts a new one). Its children
    are killed by their PDEATHSIG as it ends."""
    _stop_within(forkserver._forkserver, "_forkserver_pid")


def stop_resource_tracker() -> None:
    """End multiprocessing's resource tracker process, if one runs (it is started again by
    the next child or named semaphore that needs it)."""
    _stop_within(resource_tracker._resource_tracker, "_pid")
