"""The answer files a server process reuses (`s-<32 hex>` in the segment directory).

Writing an answer into a new file costs a page fault per 4 kB page (measured on the 2-core
machine: 23 MB written into a new tmpfs file 29–36 ms, and 14 ms with `write` into pages the
file already has), so each process keeps a few answer files mapped and copies each answer into
a free one's mapping, then links it under the request's answer name (`r-<hex>.answer`). A file
is free again when that link is gone (`st_nlink` back to 1): the client removes it once it has
copied the answer out, the service or the sweeper when the client is gone. The process holds a
lock on its files (flock, shared), so the sweepers of other processes remove them only once it
has ended. At most `MAX_FILES` files and `MAX_BYTES` bytes are kept per process; beyond, an
answer goes into a new file of its own.
"""

from __future__ import annotations

import contextlib
import fcntl
import mmap
import os
import secrets
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

MAX_FILES = 4
MAX_BYTES = 256 * 1024 * 1024
_POPULATE = getattr(mmap, "MAP_POPULATE", 0)  # pages mapped at once, not one fault each


@dataclass
class AnswerFile:
    """One answer file: its name, descriptor, and a mapping of its `size` bytes (kept, so
    that an answer is written with a copy into pages already mapped)."""

    name: str
    fd: int
    size: int = 0
    mapping: mmap.mmap | None = None
    busy: bool = False

    def write(self, views: Sequence[memoryview]) -> None:
        """Write `views` one after the other from the file's start (grown as needed, its
        memory allocated first: a full file system is an OSError here, never a SIGBUS on
        writing to the mapping)."""
        write_views(self.reserve(sum(len(v) for v in views)), views)

    def reserve(self, needed: int) -> mmap.mmap:
        """The file's mapping, grown to at least `needed` bytes (see `write`). A mapping
        replaced while arrays still view it is unmapped once they are collected."""
        if needed > self.size or self.mapping is None:
            if self.mapping is not None:
                with contextlib.suppress(BufferError):
                    self.mapping.close()
                self.mapping, self.size = None, 0
            os.posix_fallocate(self.fd, 0, max(needed, 1))
            self.mapping = mmap.mmap(self.fd, max(needed, 1), flags=mmap.MAP_SHARED | _POPULATE)
            self.size = max(needed, 1)
        return self.mapping


def write_views(mapping: mmap.mmap, views: Sequence[memoryview]) -> None:
    """Copy `views` one after the other into `mapping` from its start (which holds them)."""
    offset = 0
    for view in views:
        mapping[offset : offset + len(view)] = view
        offset += len(view)


class AnswerPool:
    """The answer files of this process in the segment directory `path`."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._files: list[AnswerFile] = []
        self._lock = threading.Lock()

    def take(self, size: int) -> AnswerFile | None:
        """A free file for an answer of `size` bytes (marked busy until `give`), or None
        when the pool is at its bounds."""
        with self._lock:
            held = sum(f.size for f in self._files)
            for file in self._files:
                if file.busy or os.fstat(file.fd).st_nlink != 1:
                    continue  # being written, or linked to an answer not yet read
                if held - file.size + max(size, file.size) <= MAX_BYTES:
                    file.busy = True
                    return file
            if len(self._files) >= MAX_FILES or held + size > MAX_BYTES:
                return None
            file = self._create()
            file.busy = True
            self._files.append(file)
            return file

    def owns(self, info: os.stat_result) -> bool:
        """Whether the file described by `info` is one of this pool's."""
        with self._lock:
            files = list(self._files)
        for file in files:
            own = os.fstat(file.fd)
            if (own.st_dev, own.st_ino) == (info.st_dev, info.st_ino):
                return True
        return False

    def give(self, file: AnswerFile) -> None:
        with self._lock:
            file.busy = False

    def _create(self) -> AnswerFile:
        name = "s-" + secrets.token_hex(16)
        temporary = f".{name}.tmp"
        flags = os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
        fd = os.open(self.path / temporary, flags, 0o600)
        fcntl.flock(fd, fcntl.LOCK_SH)  # this process's, until it ends
        os.rename(self.path / temporary, self.path / name)
        return AnswerFile(name, fd)

    def close(self) -> None:
        """Remove this process's files (at its shutdown)."""
        with self._lock:
            for file in self._files:
                with contextlib.suppress(OSError):
                    os.unlink(self.path / file.name)
                if file.mapping is not None:
                    with contextlib.suppress(BufferError):  # (unmapped when collected)
                        file.mapping.close()
                os.close(file.fd)
            self._files.clear()
