"""Binary bodies and answers through shared memory, for a client on the server's Unix socket
(`Client("unix:///path/robodyn.sock")`; the server's docs/binary-format.md, "Through shared
memory").

The server's segment directory is `<socket>.segments` (or where that links to); it must be a
directory of this user that no one else may enter, else bodies go through the socket as usual.
A request in the binary form of `SHARED_FROM` bytes or more is written, instead of sent, into
a body file of the client (`c-<32 hex>`, mode 0600, locked with flock for as long as the client
keeps it, and reused from request to request: its pages are already there), linked under a
name of its own for this request (`r-<32 hex>`) and named, with its length, in the request's
`Robodyn-Shared-Body`. The server maps it, computes, and writes a binary answer into
`r-<32 hex>.answer`, named with its length in the answer's `Robodyn-Shared-Answer`. The client
copies the answer out (the file is the server's, reused for later answers; the arrays are the
caller's) and removes both names. The lock tells the server that the client is still there: a
client killed mid-request leaves files nobody holds, which the server removes.
"""

from __future__ import annotations

import contextlib
import fcntl
import mmap
import os
import secrets
import stat
import threading
from collections.abc import Sequence

import numpy as np

from robodyn.answer_memory import AnswerMemory
from robodyn.errors import ResponseFormatError

BODY_HEADER = "Robodyn-Shared-Body"
ANSWER_HEADER = "robodyn-shared-answer"
ANSWER_SUFFIX = ".answer"
SHARED_FROM = 64 * 1024
"""Binary request bodies of this many bytes or more go through shared memory (smaller ones
cost more in file operations than they save in copies)."""
KEPT_FILES = 4  # idle body files a client keeps for its next requests
KEPT_ANSWER_FILES = 4  # mappings of the server's answer files a client keeps
_POPULATE = getattr(mmap, "MAP_POPULATE", 0)  # pages mapped at once, not one fault each


def directory_of(socket_path: str) -> str:
    """The server's segment directory for the Unix socket `socket_path`."""
    return socket_path + ".segments"


def _private_directory(path: str) -> int | None:
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


class BodyFile:
    """A client's body file (`c-<32 hex>`), locked while it exists; `create` makes one. Its
    pages stay mapped from body to body (`write`)."""

    def __init__(self, directory: int, fd: int, name: str) -> None:
        self.directory, self.fd, self.name = directory, fd, name
        self.size = 0  # bytes allocated and mapped
        self.mapping: mmap.mmap | None = None

    def write(self, parts: Sequence[bytes | memoryview]) -> int:
        """Copy `parts` one after the other into the file from its start; the number of
        bytes. The file grows as needed, its memory allocated first (`posix_fallocate`: a
        full file system is an OSError here, never a SIGBUS on writing to the mapping), and
        stays mapped: copying 9.2 MB into mapped pages takes about 0.4 ms, writing them with
        `pwritev` 1.7 ms."""
        views = [memoryview(p).cast("B") for p in parts if len(p)]
        needed = sum(len(v) for v in views)
        if needed > self.size:
            if self.mapping is not None:
                _close_quietly(self.mapping)
                self.mapping, self.size = None, 0
            os.posix_fallocate(self.fd, 0, needed)
            self.mapping = mmap.mmap(self.fd, needed, flags=mmap.MAP_SHARED | _POPULATE)
            self.size = needed
        mapping, offset = self.mapping, 0
        for view in views:
            mapping[offset : offset + len(view)] = view  # type: ignore[index]
            offset += len(view)
        return needed

    @classmethod
    def create(cls, directory: str) -> BodyFile | None:
        """A new locked body file in the private directory `directory`; None when there is
        no such directory, or no room."""
        dir_fd = _private_directory(directory)
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
            _close_quietly(self.mapping)
            self.mapping = None
        with contextlib.suppress(OSError):
            os.unlink(self.name, dir_fd=self.directory)
        os.close(self.fd)
        os.close(self.directory)


class Segment:
    """One request's body in shared memory: `name` and `length` go in its header; `answer`
    reads the answer; `release` always."""

    def __init__(self, pool: SharedMemory, file: BodyFile, name: str, length: int) -> None:
        self._pool, self._file, self.name, self.length = pool, file, name, length

    @property
    def header(self) -> str:
        return f"{self.name} {self.length}"

    def answer(self, value: str, status: int) -> memoryview:
        """The answer named by `Robodyn-Shared-Answer: <name> <length>`, copied out into
        memory of the caller's (writable); its name is removed."""
        name, _, length = value.partition(" ")
        if name != self.name + ANSWER_SUFFIX or not length.isdigit():
            raise ResponseFormatError(
                f"the server named {value[:80]!r} as the answer to segment {self.name}",
                status=status,
            )
        directory = self._file.directory
        try:
            fd = os.open(name, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC, dir_fd=directory)
        except OSError as exc:
            raise ResponseFormatError(
                f"the answer segment {name} cannot be opened ({exc.strerror})", status=status
            ) from None
        try:
            info = os.fstat(fd)
            size = int(length)
            if (
                not stat.S_ISREG(info.st_mode)
                or info.st_uid != os.geteuid()
                or stat.S_IMODE(info.st_mode) & 0o077
                or not 8 <= size <= info.st_size
            ):
                raise ResponseFormatError(
                    f"the answer segment {name} is not a private file of this user holding "
                    "the answer",
                    status=status,
                )
        except BaseException:
            os.close(fd)
            raise
        finally:
            with contextlib.suppress(OSError):
                os.unlink(name, dir_fd=directory)
        return self._pool.copy_out(fd, info, size)  # (takes the descriptor)

    def release(self) -> None:
        """Remove this request's names (body and answer); the body file is kept for the
        client's next request."""
        for each in (self.name + ANSWER_SUFFIX, self.name):
            with contextlib.suppress(OSError):
                os.unlink(each, dir_fd=self._file.directory)
        self._pool.give(self._file)


class SharedMemory:
    """The body files of one client of the Unix socket `socket_path` (one per request in
    flight, `KEPT_FILES` kept idle); `close` removes them."""

    def __init__(self, socket_path: str, memory: AnswerMemory | None = None) -> None:
        self.directory = directory_of(socket_path)
        self._memory = AnswerMemory() if memory is None else memory
        self._idle: list[BodyFile] = []
        self._answers: dict[tuple[int, int], tuple[int, mmap.mmap]] = {}  # oldest first
        self._lock = threading.Lock()

    def segment(self, parts: Sequence[bytes | memoryview]) -> Segment | None:
        """The body `parts` written into a body file, linked under a new request name; None
        when it cannot be (the body then goes through the socket)."""
        with self._lock:
            file = self._idle.pop() if self._idle else None
        if file is None:
            file = BodyFile.create(self.directory)
            if file is None:
                return None
        name = "r-" + secrets.token_hex(16)
        try:
            length = file.write(parts)
            os.link(file.name, name, src_dir_fd=file.directory, dst_dir_fd=file.directory)
        except OSError:
            file.close()  # (gone from under us, or no room: not kept)
            return None
        return Segment(self, file, name, length)

    def copy_out(self, fd: int, info: os.stat_result, size: int) -> memoryview:
        """The first `size` bytes of the answer file open as `fd` (described by `info`),
        copied into memory of the caller's (`AnswerMemory`: reused once the arrays of an
        earlier answer are gone). The file's mapping is kept for the next answer in the same
        file (the server reuses a few, and mapping 23 MB anew costs page faults); so is its
        descriptor, which keeps the inode, and so the identity of the mapping, alive."""
        key = (info.st_dev, info.st_ino)
        with self._lock:
            cached = self._answers.pop(key, None)
            if cached is not None and len(cached[1]) >= size:
                os.close(fd)
                fd, mapping = cached
            else:
                if cached is not None:
                    _close_mapping(*cached)
                try:
                    mapping = mmap.mmap(
                        fd, info.st_size, flags=mmap.MAP_SHARED | _POPULATE, prot=mmap.PROT_READ
                    )
                except BaseException:
                    os.close(fd)
                    raise
            self._answers[key] = (fd, mapping)
            while len(self._answers) > KEPT_ANSWER_FILES:
                _close_mapping(*self._answers.pop(next(iter(self._answers))))
            content = self._memory.take(size)
            np.frombuffer(content, dtype=np.uint8)[:] = np.frombuffer(
                mapping, dtype=np.uint8, count=size
            )
        return content

    def give(self, file: BodyFile) -> None:
        with self._lock:
            if len(self._idle) < KEPT_FILES:
                self._idle.append(file)
                return
        file.close()

    def close(self) -> None:
        with self._lock:
            idle, self._idle = self._idle, []
            answers, self._answers = self._answers, {}
        for file in idle:
            file.close()
        for cached in answers.values():
            _close_mapping(*cached)


def _close_mapping(fd: int, mapping: mmap.mmap) -> None:
    _close_quietly(mapping)
    os.close(fd)


def _close_quietly(mapping: mmap.mmap) -> None:
    """Unmap, unless arrays still view the mapping (it is unmapped once they are collected)."""
    with contextlib.suppress(BufferError):
        mapping.close()
