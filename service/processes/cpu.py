"""CPU time of a child, and whether a child that ran out of wall-clock time was starved.

A child that timed out having run on a CPU for less than `STARVED_CPU_FRACTION` of its time
was held back by the machine's load, not by its work: the caller answers 503 overloaded
(retry later), not a 422 about the input.
"""

from __future__ import annotations

import os

STARVED_CPU_FRACTION = 0.5
"""A child that timed out having run on a CPU for less than this fraction of its wall-clock
time was starved by the machine's load: the answer is 503 overloaded, not an invalid input."""


def cpu_seconds(pid: int) -> float | None:
    """CPU time (user + system, s) a live process has used, from /proc/<pid>/stat (None where
    unknown: not Linux, or the process is gone)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            fields = fh.read().rsplit(b")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return None


def starved(cpu_s: float | None, wall_s: float) -> bool:
    """Whether `cpu_s` seconds of CPU in `wall_s` seconds of wall clock is less than
    `STARVED_CPU_FRACTION` of it (False where the CPU time is unknown)."""
    return cpu_s is not None and cpu_s < STARVED_CPU_FRACTION * wall_s
