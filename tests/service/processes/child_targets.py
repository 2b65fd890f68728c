"""Work for the children of the tests of `service.processes` (module-level functions: a child
finds its target by name)."""

from __future__ import annotations

import os
import resource
import signal
import time
from typing import Any


def report_limits(conn: Any) -> None:
    """Send what the kernel says the child may use: its rlimits and its nice value."""
    conn.send(
        {
            "as": resource.getrlimit(resource.RLIMIT_AS),
            "cpu": resource.getrlimit(resource.RLIMIT_CPU),
            "core": resource.getrlimit(resource.RLIMIT_CORE),
            "nofile": resource.getrlimit(resource.RLIMIT_NOFILE),
            "nice": os.nice(0),
        }
    )


def reverse_bytes(conn: Any) -> None:
    """Receive bytes, send them back reversed."""
    conn.send(conn.recv_bytes()[::-1])


def sleep(conn: Any, seconds: float) -> None:
    time.sleep(seconds)


def spin(conn: Any) -> None:
    """Use the CPU until killed."""
    while True:
        pass


def crash(conn: Any) -> None:
    os.kill(os.getpid(), signal.SIGSEGV)


def allocate(conn: Any, mb: int) -> None:
    """Try to allocate `mb` MB; send "ok" or "memory error"."""
    try:
        block = bytearray(mb * 1024 * 1024)
        conn.send(f"ok {len(block)}")
    except MemoryError:
        conn.send("memory error")


def address_space_mb(conn: Any) -> None:
    """Send the child's address space now (VmSize), MB."""
    with open("/proc/self/status") as fh:
        size_kb = next(int(line.split()[1]) for line in fh if line.startswith("VmSize:"))
    conn.send(size_kb // 1024)


def ready_then_sleep(conn: Any, seconds: float) -> None:
    """Say "ready" (the watchdog is set by then), then sleep."""
    conn.send("ready")
    time.sleep(seconds)


def serve_shared_file(conn: Any) -> None:
    """A resident helper: receive a shared file's descriptor, say ready, then for each
    (size, offset, data) write `data` at `offset` of the file mapped at `size` and answer its
    length; ("sleep", s) sleeps s seconds first."""
    import mmap
    from multiprocessing.reduction import recv_handle

    fd = recv_handle(conn)
    conn.send("ready")
    while True:
        try:
            message = conn.recv()
        except EOFError:
            return
        if message[0] == "sleep":
            time.sleep(message[1])
            conn.send("slept")
            continue
        size, offset, data = message
        with mmap.mmap(fd, size) as mapping:
            mapping[offset : offset + len(data)] = data
        conn.send(len(data))
