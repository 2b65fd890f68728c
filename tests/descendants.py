"""The processes descended from a process (children, their children, ...), read from Linux's
/proc: what the suite checks to leave no process behind (psutil is not a dependency)."""

from __future__ import annotations

import time
from pathlib import Path

PROC = Path("/proc")


def _stat(pid: int) -> list[bytes] | None:
    """The fields of /proc/<pid>/stat after "(comm)": state, ppid, ... (None: gone)."""
    try:
        return (PROC / str(pid) / "stat").read_bytes().rsplit(b")", 1)[1].split()
    except (OSError, IndexError):
        return None


def command_line(pid: int) -> str:
    try:
        return (PROC / str(pid) / "cmdline").read_bytes().replace(b"\0", b" ").decode().strip()
    except OSError:
        return "?"


def descendants(pid: int) -> dict[int, str]:
    """Every live process below `pid` in the process tree, with its command line (zombies,
    ended but not reaped by their parent, included: they are left behind too)."""
    parents: dict[int, int] = {}
    for entry in PROC.iterdir():
        if entry.name.isdigit():
            fields = _stat(int(entry.name))
            if fields is not None:
                parents[int(entry.name)] = int(fields[1])
    found: dict[int, str] = {}
    frontier = {pid}
    while frontier:
        below = {child for child, parent in parents.items() if parent in frontier}
        below -= found.keys()
        found.update({child: command_line(child) for child in below})
        frontier = below
    return found


def ended(pid: int) -> bool:
    """Whether `pid` is gone or a zombie (dead, waiting to be reaped by its new parent)."""
    fields = _stat(pid)
    return fields is None or fields[0] in (b"Z", b"X")


def wait_ended(pids: list[int] | set[int], timeout_s: float) -> set[int]:
    """Wait until every pid has ended, at most `timeout_s` seconds: those still running."""
    deadline = time.monotonic() + timeout_s
    while True:
        running = {pid for pid in pids if not ended(pid)}
        if not running or time.monotonic() > deadline:
            return running
        time.sleep(0.05)


def wait_no_descendants(pid: int, timeout_s: float) -> dict[int, str]:
    """Wait until `pid` has no descendant left, at most `timeout_s` seconds: those left."""
    deadline = time.monotonic() + timeout_s
    while True:
        left = descendants(pid)
        if not left or time.monotonic() > deadline:
            return left
        time.sleep(0.05)
