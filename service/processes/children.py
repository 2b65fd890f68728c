"""One child process: started limited and watched, asked for one answer within a timeout,
killed and reaped.

`start_child(target, args, ...)` starts `target(conn, *args)` in a child (forked from the
forkserver, or spawned from the launcher thread) that first calls `watchdog.die_with_parent`
and applies its `ResourceLimits`, then runs `target` with its end of a pipe. `run_child` is the
short-lived case: start, optionally send bytes, wait at most `timeout_s` of wall clock for one
answer, then kill and reap the child whatever happened. Its outcomes:

- the object the child sent;
- `ChildNotStarted`: no process could be started (no processes or descriptors left: the
  server's condition, callers answer 503);
- `ChildTimedOut`: no answer within `timeout_s` (the child is killed); `cpu_s` says how much
  CPU it had, so that a starved child (`cpu.starved`) is told from a slow one;
- `ChildDied`: the child ended without an answer (a crash, a signal, a limit); `exitcode` is
  its exit code (negative: the signal).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Any, Literal

from service.processes.contexts import forkserver_context, launch, spawn_context
from service.processes.cpu import cpu_seconds, starved
from service.processes.limits import ResourceLimits
from service.processes.tracking import end, track
from service.processes.watchdog import die_with_parent


class ChildNotStarted(Exception):
    """No child process could be started."""


class ChildTimedOut(Exception):
    """The child gave no answer within its time; `cpu_s`: the CPU time it had (None: unknown)."""

    def __init__(self, cpu_s: float | None) -> None:
        super().__init__(f"no answer in time (CPU time {cpu_s} s)")
        self.cpu_s = cpu_s

    def starved(self, wall_s: float) -> bool:
        """Whether the child had less than `cpu.STARVED_CPU_FRACTION` of `wall_s` on a CPU."""
        return starved(self.cpu_s, wall_s)


class ChildDied(Exception):
    """The child ended without an answer; `exitcode` (negative: killed by that signal)."""

    def __init__(self, exitcode: int | None) -> None:
        super().__init__(f"the child ended without an answer (exit code {exitcode})")
        self.exitcode = exitcode


def _child_main(target: Callable[..., Any], limits: ResourceLimits, *args: Any) -> None:
    """The first code of every child: the watchdog, the limits, then the work."""
    die_with_parent()
    limits.apply()
    target(*args)


def start_child(
    target: Callable[..., Any],
    args: Iterable[Any] = (),
    *,
    limits: ResourceLimits,
    start: Literal["forkserver", "spawn"] = "forkserver",
    preload: Iterable[str] = (),
    duplex: bool = False,
    name: str | None = None,
) -> tuple[BaseProcess, Connection]:
    """`target(conn, *args)` started in a child (a module-level function: it is pickled by
    name); returns the child and the parent's end of the pipe (read-only unless `duplex`).
    `preload`: modules the forkserver imports when it starts (`contexts`). Raises
    `ChildNotStarted`. The child is tracked until `tracking.end(proc)`."""
    context = forkserver_context(preload) if start == "forkserver" else spawn_context()
    parent, child = context.Pipe(duplex=duplex)
    proc = context.Process(
        target=_child_main, args=(target, limits, child, *args), daemon=True, name=name
    )
    try:
        if start == "spawn":
            launch(proc.start)  # PDEATHSIG follows the thread that started it
        else:
            proc.start()  # forked by the forkserver: its parent is the forkserver
    except OSError:
        parent.close()
        raise ChildNotStarted from None
    finally:
        child.close()
    track(proc)
    return proc, parent


def run_child(
    target: Callable[..., Any],
    args: Iterable[Any] = (),
    *,
    timeout_s: float,
    limits: ResourceLimits,
    preload: Iterable[str] = (),
    send_bytes: bytes | None = None,
) -> Any:
    """The one object `target(conn, *args)` sends on `conn`, from a child forked by the
    forkserver, within `timeout_s` seconds of wall clock from its start (after `send_bytes`,
    if given, is sent to the child first, on the same pipe). The child is killed and reaped
    on every outcome; see the module docstring for the exceptions. Blocking: call it off the
    event loop."""
    proc, conn = start_child(
        target, args, limits=limits, preload=preload, duplex=send_bytes is not None
    )
    try:
        if send_bytes is not None:
            conn.send_bytes(send_bytes)
        if not conn.poll(timeout_s):
            raise ChildTimedOut(cpu_seconds(proc.pid) if proc.pid else None)
        return conn.recv()
    except (EOFError, OSError):
        proc.join(5)
        raise ChildDied(proc.exitcode) from None
    finally:
        conn.close()
        end(proc)
