"""One child process: started limited and watched, asked for one answer within a timeout,
killed and reaped.

`start_child(target, args, ...)` starts `target(conn, *args)` in a child (forked from the
forkserver, or spawned from the launcher thread) that first calls `watchdog.die_with_parent`
and applies its `ResourceLimits`, then runs `target` with its end of a pipe. A forkserver that
does not start the child within `START_TIMEOUT_S` (stopped, hung; `FIRST_START_TIMEOUT_S` for
the child that starts it) is killed, and a new one serves the next child. `run_child` is the
short-lived case: start, optionally send bytes, wait at most `timeout_s` of wall clock for one
answer, then kill and reap the child whatever happened. Every wait is bounded: the child is
killed at its deadline even while the parent is blocked sending it bytes or reading an answer
it stopped sending halfway (a stopped child). Its outcomes:

- the object the child sent;
- `ChildNotStarted`: no process could be started (no processes or descriptors left, or a
  forkserver that did not answer: the server's condition, callers answer 503);
- `ChildTimedOut`: no answer within `timeout_s` (the child is killed); `cpu_s` says how much
  CPU it had, so that a starved child (`cpu.starved`) is told from a slow one;
- `ChildDied`: the child ended without an answer (a crash, a signal, a limit); `exitcode` is
  its exit code (negative: the signal), `cpu_s` the CPU time it was last seen with, so that a
  SIGKILL from outside (the kernel's OOM killer: `killed_from_outside`) is told from its own
  CPU limit's.
"""

from __future__ import annotations

import contextlib
import signal
import threading
import time
from collections.abc import Callable, Iterable
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Any, Literal

from service.processes.contexts import (
    forkserver_context,
    forkserver_running,
    kill_forkserver,
    launch,
    spawn_context,
)
from service.processes.cpu import cpu_seconds, starved
from service.processes.limits import ResourceLimits
from service.processes.tracking import end, track
from service.processes.watchdog import die_with_parent

START_TIMEOUT_S = 10.0
"""At most this long for a running forkserver to start a child (a fork: milliseconds); beyond,
the forkserver is killed and the child not started."""
FIRST_START_TIMEOUT_S = 60.0
"""The same for the child that starts the forkserver (it imports the preloaded modules first:
seconds, more on a busy machine)."""
SAMPLE_S = 1.0
"""A parent waiting for its child's answer reads the child's CPU time this often."""


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
    """The child ended without an answer; `exitcode` (negative: killed by that signal);
    `cpu_s`: its CPU time when last seen, at most `SAMPLE_S` before it ended (None:
    unknown)."""

    def __init__(self, exitcode: int | None, cpu_s: float | None = None) -> None:
        super().__init__(f"the child ended without an answer (exit code {exitcode})")
        self.exitcode = exitcode
        self.cpu_s = cpu_s

    def killed_from_outside(self, cpu_limit_s: int | None) -> bool:
        """Whether the child was killed by SIGKILL from outside (the kernel's OOM killer, an
        operator), not by its own limits: a SIGKILL while its CPU time was below
        `cpu_limit_s` (the CPU limit kills with SIGXCPU at `cpu_limit_s` and SIGKILL one
        second later). The machine's condition, not the input's: callers answer 503."""
        if self.exitcode != -signal.SIGKILL:
            return False
        return cpu_limit_s is None or (self.cpu_s is not None and self.cpu_s < cpu_limit_s)


def killed_detail(what: str, exitcode: int | None) -> str:
    """The detail of a 503 for a process killed from outside (`ChildDied.killed_from_outside`):
    `what` ("the model builder") was killed by signal N."""
    number = -exitcode if exitcode is not None and exitcode < 0 else signal.SIGKILL
    name = signal.Signals(number).name if number in signal.valid_signals() else str(number)
    return (
        f"{what} was killed by signal {number} ({name}) from outside the server, not by its "
        "own limits: the machine may be out of memory; retry shortly"
    )


def _child_main(target: Callable[..., Any], limits: ResourceLimits, *args: Any) -> None:
    """The first code of every child: the watchdog, the limits, then the work."""
    die_with_parent()
    limits.apply()
    target(*args)


def _start_forked(proc: BaseProcess) -> None:
    """`proc.start()` through the forkserver, within `START_TIMEOUT_S` (`FIRST_START_TIMEOUT_S`
    when no forkserver runs yet): a forkserver that does not answer is killed, which ends the
    wait (an `OSError` or `EOFError` here)."""
    running = forkserver_running()
    watch = threading.Timer(START_TIMEOUT_S if running else FIRST_START_TIMEOUT_S, kill_forkserver)
    watch.daemon = True
    watch.start()
    try:
        proc.start()
    finally:
        watch.cancel()


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
            _start_forked(proc)  # forked by the forkserver: its parent is the forkserver
    except (OSError, EOFError):
        parent.close()
        raise ChildNotStarted from None
    finally:
        child.close()
    track(proc)
    return proc, parent


class _Deadline:
    """Kills `proc` at `timeout_s` from now, noting its CPU time first: whatever the parent is
    blocked on (sending, receiving) then ends. `cpu_s` is also sampled by `sample()`."""

    def __init__(self, proc: BaseProcess, timeout_s: float) -> None:
        self.proc = proc
        self.at = time.monotonic() + timeout_s
        self.cpu_s = cpu_seconds(proc.pid) if proc.pid else None
        self.fired = False
        self._timer = threading.Timer(timeout_s, self.fire)
        self._timer.daemon = True
        self._timer.start()

    def sample(self) -> None:
        seen = cpu_seconds(self.proc.pid) if self.proc.pid else None
        if seen is not None:
            self.cpu_s = seen

    def fire(self) -> None:
        if not self.fired:
            self.sample()
            self.fired = True
            with contextlib.suppress(OSError):
                self.proc.kill()

    def cancel(self) -> None:
        self._timer.cancel()


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
    deadline = _Deadline(proc, timeout_s)
    try:
        if send_bytes is not None:
            conn.send_bytes(send_bytes)
        while not conn.poll(max(0.0, min(SAMPLE_S, deadline.at - time.monotonic()))):
            if time.monotonic() >= deadline.at:
                deadline.fire()
                raise ChildTimedOut(deadline.cpu_s)
            deadline.sample()
        return conn.recv()
    except (EOFError, OSError):
        proc.join(5)
        if deadline.fired:
            raise ChildTimedOut(deadline.cpu_s) from None
        raise ChildDied(proc.exitcode, deadline.cpu_s) from None
    finally:
        deadline.cancel()
        conn.close()
        end(proc)
