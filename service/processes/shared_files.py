"""Anonymous shared-memory files (Linux `memfd_create`) for answers written by helper processes.

A `SharedFile` is a file in memory with no name in any file system: its descriptor is handed
to a helper (`multiprocessing.reduction.send_handle` over the helper's pipe), both processes
map it, and the helper writes its part of an answer there instead of sending it through the
pipe. It is grown on demand up to `max_bytes` and kept, mapped, for the next request: pages
already written cost a copy, new pages a fault each (about 30 ms for 23 MB on a loaded
machine against a few ms). Nothing is left behind: the file ends with its last descriptor or
mapping, so with this process and its helpers (whatever ends them).
"""

from __future__ import annotations

import mmap
import os

GROW_STEP = 1 << 20  # the file grows in whole MiB


class SharedFile:
    """An anonymous shared-memory file of at most `max_bytes`, mapped in this process. Not
    thread-safe: one user at a time (the helper that owns it)."""

    def __init__(self, max_bytes: int, name: str = "robodyn-shared") -> None:
        self.max_bytes = max_bytes
        self.fd = os.memfd_create(name, os.MFD_CLOEXEC)
        self.size = 0
        self.map: mmap.mmap | None = None

    def reserve(self, nbytes: int) -> bool:
        """Make the file at least `nbytes` long (whole MiB, remapped when it grows); False
        when that is more than `max_bytes` (the file is unchanged)."""
        if nbytes > self.max_bytes:
            return False
        if nbytes > self.size or self.map is None:
            size = min(self.max_bytes, -(-max(nbytes, 1) // GROW_STEP) * GROW_STEP)
            size = max(size, nbytes)
            if self.map is not None:
                self.map.close()
                self.map = None
            os.ftruncate(self.fd, size)
            self.map = mmap.mmap(self.fd, size)
            self.size = size
        return True

    def close(self) -> None:
        """Unmap and close (the memory is freed once the helpers' mappings are gone too)."""
        if self.map is not None:
            self.map.close()
            self.map = None
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


def map_shared_file(fd: int, size: int) -> mmap.mmap:
    """The helper's side: map `size` bytes of a shared file received as `fd`."""
    return mmap.mmap(fd, size)
