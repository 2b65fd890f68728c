"""A long-lived helper process that answers messages on its pipe, one at a time, each within a
bounded wait, and is killed when it does not.

`ResidentHelper(target, limits)` starts `target(conn)` in a spawned child (`children`: the
watchdog, the limits, tracked for `tracking.shutdown`) on first `start()`. The child sends one
message when it is ready to serve (its imports done); `ready()` tells, without waiting.
`ask(message, timeout_s)` sends a message and waits at most `timeout_s` for the reply: a child
that ended raises `ChildDied`, one that did not answer in time is killed and raises
`ChildTimedOut` (its CPU time tells a starved child from a hung one); either way the helper is
stopped and a later `start()` starts a new one. `send_handle(fd)` hands the child a file
descriptor (a `shared_files.SharedFile`). Callers take the helper's `lock` (without waiting:
a busy helper is not waited for) around their use.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from multiprocessing.reduction import send_handle
from typing import Any

from service.processes.children import ChildDied, ChildTimedOut, start_child
from service.processes.cpu import cpu_seconds
from service.processes.limits import ResourceLimits
from service.processes.tracking import disown, end, own


class ResidentHelper:
    """One long-lived helper (module docstring)."""

    def __init__(
        self, target: Callable[..., Any], limits: ResourceLimits, name: str = "robodyn-helper"
    ) -> None:
        self.target = target
        self.limits = limits
        self.name = name
        self.lock = threading.Lock()  # one user at a time
        self.proc: BaseProcess | None = None
        self.conn: Connection | None = None
        self.is_ready = False
        self.generation = 0  # counts the helpers started: state kept for one is not the next's

    @property
    def running(self) -> bool:
        return self.proc is not None and self.proc.is_alive()

    def start(self) -> None:
        """Start the child (raises `ChildNotStarted`); nothing when one runs."""
        if self.running:
            return
        self.stop()
        self.proc, self.conn = start_child(
            self.target, limits=self.limits, start="spawn", duplex=True, name=self.name
        )
        self.generation += 1
        own(self)

    def ready(self) -> bool:
        """Whether the child has said it is ready (its first message); never waits. A child
        that ended before is stopped."""
        if self.is_ready:
            return True
        if self.conn is None or self.proc is None:
            return False
        try:
            if self.conn.poll(0):
                self.conn.recv()
                self.is_ready = True
        except (EOFError, OSError):
            self.stop()
        return self.is_ready

    def send_handle(self, fd: int) -> None:
        """Hand the child a duplicate of the file descriptor `fd`."""
        assert self.conn is not None and self.proc is not None and self.proc.pid is not None
        send_handle(self.conn, fd, self.proc.pid)

    def send(self, message: Any) -> None:
        """Send a message that has no reply of its own (e.g. data a later message uses)."""
        assert self.conn is not None
        self.conn.send(message)

    def ask(self, message: Any, timeout_s: float) -> Any:
        """The child's reply to `message` within `timeout_s` (module docstring)."""
        with contextlib.suppress(OSError):  # a child that ended: told by `wait_reply`
            self.send(message)
        return self.wait_reply(timeout_s)

    def wait_reply(self, timeout_s: float) -> Any:
        """The reply to a message sent by `send`, within `timeout_s` (as `ask`)."""
        assert self.conn is not None and self.proc is not None
        proc, conn = self.proc, self.conn
        try:
            if conn.poll(max(0.0, timeout_s)):
                return conn.recv()
        except (EOFError, OSError):
            proc.join(1.0)
            exitcode = proc.exitcode
            self.stop()
            raise ChildDied(exitcode) from None
        cpu_s = cpu_seconds(proc.pid) if proc.pid else None
        self.stop()
        raise ChildTimedOut(cpu_s)

    def stop(self) -> None:
        """Kill and reap the child, if one runs (a later `start` starts a new one)."""
        proc, conn = self.proc, self.conn
        self.proc, self.conn, self.is_ready = None, None, False
        if conn is not None:
            with contextlib.suppress(OSError):
                conn.close()
        if proc is not None:
            end(proc)
        disown(self)

    def close(self) -> None:
        """`stop` (for `tracking.shutdown`)."""
        self.stop()
