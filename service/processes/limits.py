"""Resource limits a child process sets on itself before it runs untrusted or long work.

`ResourceLimits.apply` runs first in every child this package starts (`children`, `pools`):
a lower CPU priority (`os.nice`), an address-space limit (`RLIMIT_AS`: an allocation beyond it
fails, as `MemoryError` in Python or `std::bad_alloc` in C++), a CPU-time limit (`RLIMIT_CPU`:
SIGXCPU at the soft limit, SIGKILL one second later at the hard one), no core files, and
optionally few file descriptors. `forbid_file_writes` is separate: a builder calls it once the
files it needs are written. Linux and other Unix (`setrlimit`).
"""

from __future__ import annotations

import os
import resource
from dataclasses import dataclass

CHILD_NICENESS = 10
"""Children run at a lower CPU priority than the serving process: their work is background
work, answers to requests are not (a starved child ends as 503 overloaded, see `cpu`)."""


@dataclass(frozen=True)
class ResourceLimits:
    """What a child may use (None: not limited).

    memory_mb   address space, MB (`RLIMIT_AS`, soft = hard)
    cpu_s       CPU time, s (`RLIMIT_CPU`: soft cpu_s, hard cpu_s + 1)
    open_files  file descriptors (`RLIMIT_NOFILE`, soft = hard)
    niceness    added to the child's nice value (`os.nice`)
    """

    memory_mb: int | None = None
    cpu_s: int | None = None
    open_files: int | None = None
    niceness: int = CHILD_NICENESS

    def apply(self) -> None:
        """Set the limits on the calling process (a child, before its work); no core files."""
        if self.niceness:
            os.nice(self.niceness)
        if self.memory_mb is not None:
            memory = self.memory_mb * 1024 * 1024
            resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
        if self.cpu_s is not None:
            resource.setrlimit(resource.RLIMIT_CPU, (self.cpu_s, self.cpu_s + 1))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
        if self.open_files is not None:
            resource.setrlimit(resource.RLIMIT_NOFILE, (self.open_files, self.open_files))


def forbid_file_writes() -> None:
    """No file of the calling process may grow from now on (`RLIMIT_FSIZE` = 0: a write is
    refused with SIGXFSZ/EFBIG)."""
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
