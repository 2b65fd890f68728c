"""A co-located client's files in the server's segment directory (`c-<32 hex>`): its body
files and answer rooms (`robodyn.shared_memory`), each locked by the client while it has it."""

from __future__ import annotations

import contextlib
import fcntl
import mmap
import os
import secrets
import stat
from collections.abc import Sequence

import numpy as np

from robodyn.parallel_copy import copy_into

_POPULATE = getattr(mmap, "MAP_POPULATE", 0)  # pages mapped at once, not one fault each


def private_directory(path: str) -> int | None:
    """A descriptor of the directory `path` (or of the directory it links to) when it is
    this user's and private (mode 0700 or less), else None."""
    flags = os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC
    try:
        fd = os.open(os.path.realpath(path), flags)
    except OSError:
        return None
    info = os.fstat(fd)
    if info.st_uid != os.geteuid() or stat.S_IMODE(info.st_mode) & 0o077:
        os.close(fd)
        return None
    return fd


class ClientFile:
    """A client's body file or answer room (`c-<32 hex>`), locked while it exists; `create`
    makes one. Its pages stay mapped from body to body (`write`), or answer to answer
    (`mapped`)."""

    def __init__(self, directory: int, fd: int, name: str) -> None:
        self.directory, self.fd, self.name = directory, fd, name
        self.size = 0  # bytes allocated and mapped
        self.mapping: mmap.mmap | None = None
        info = os.fstat(fd)
        self.identity = (info.st_dev, info.st_ino)

    def mapped(self, size: int) -> mmap.mmap | None:
        """A mapping of at least the first `size` bytes of the file as it is (an answer room,
        grown by the server), mapped anew only when the kept one is shorter; None when the
        file holds fewer."""
        if size > self.size or self.mapping is None:
            length = os.fstat(self.fd).st_size
            if length < max(size, 1):
                return None
            if self.mapping is not None:
                close_quietly(self.mapping)
                self.mapping, self.size = None, 0
            self.mapping = mmap.mmap(self.fd, length, flags=mmap.MAP_SHARED | _POPULATE)
            self.size = length
        return self.mapping

    def write(self, parts: Sequence[bytes | memoryview]) -> int:
        """Copy `parts` one after the other into the file from its start; the number of
        bytes. The file grows as needed, its memory allocated first (`posix_fallocate`: a
        full file system is an OSError here, never a SIGBUS on writing to the mapping), and
        stays mapped: copying 9.2 MB into mapped pages takes about 0.4 ms (caches warm; on two
        threads, `parallel_copy`), writing them with `pwritev` 1.7 ms."""
        views = [memoryview(p).cast("B") for p in parts if len(p)]
        needed = sum(len(v) for v in views)
        if needed > self.size:
            if self.mapping is not None:
                close_quietly(self.mapping)
                self.mapping, self.size = None, 0
            os.posix_fallocate(self.fd, 0, needed)
            self.mapping = mmap.mmap(self.fd, needed, flags=mmap.MAP_SHARED | _POPULATE)
            self.size = needed
        assert self.mapping is not None  # (mapped above)
        copy_into(np.frombuffer(self.mapping, dtype=np.uint8, count=needed), views)
        return needed

    @classmethod
    def create(cls, directory: str) -> ClientFile | None:
        """A new locked file in the private directory `directory`; None when there is no such
        directory, or no room."""
        dir_fd = private_directory(directory)
        if dir_fd is None:
            return None
        name = "c-" + secrets.token_hex(16)
        temporary = f".{name}.tmp"
        flags = os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
        try:
            fd = os.open(temporary, flags, 0o600, dir_fd=dir_fd)
        except OSError:
            os.close(dir_fd)
            return None
        try:
            fcntl.flock(fd, fcntl.LOCK_SH)  # held until `close`, or the process ends
            os.rename(temporary, name, src_dir_fd=dir_fd, dst_dir_fd=dir_fd)
        except OSError:
            with contextlib.suppress(OSError):
                os.unlink(temporary, dir_fd=dir_fd)
            os.close(fd)
            os.close(dir_fd)
            return None
        return cls(dir_fd, fd, name)

    def close(self) -> None:
        if self.mapping is not None:
            close_quietly(self.mapping)
            self.mapping = None
        with contextlib.suppress(OSError):
            os.unlink(self.name, dir_fd=self.directory)
        os.close(self.fd)
        os.close(self.directory)


def close_quietly(mapping: mmap.mmap) -> None:
    """Unmap, unless arrays still view the mapping (it is unmapped once they are collected)."""
    with contextlib.suppress(BufferError):
        mapping.close()
