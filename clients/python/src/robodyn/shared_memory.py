"""Binary bodies and answers through shared memory, for a client on the server's Unix socket
(`Client("unix:///path/robodyn.sock")`; the server's docs/binary-format.md, "Through shared
memory").

A request in the binary form of `SHARED_FROM` bytes or more is written, instead of sent, into
a file of the server's segment directory (`<socket>.segments`, or where that links to, which
must be a directory of this user that no one else may enter, else the body goes through the
socket as usual):

    .r-<32 hex>.tmp   created (mode 0600), locked (flock, shared) and written,
    r-<32 hex>        then renamed, and named in the request's `Robodyn-Shared-Body`.

The server maps it, and writes a binary answer into `r-<32 hex>.answer`, named in the answer's
`Robodyn-Shared-Answer`. The client maps the answer privately (copy-on-write: its arrays are
writable views, and writing to them changes nothing shared), then removes both files and lets
its lock go; arrays outlive the files. The lock is what tells the server that the client is
still there: a client killed mid-request leaves unlocked files, which the server removes.
"""

from __future__ import annotations

import contextlib
import fcntl
import mmap
import os
import secrets
import stat
from collections.abc import Sequence

from robodyn.errors import ResponseFormatError

BODY_HEADER = "Robodyn-Shared-Body"
ANSWER_HEADER = "robodyn-shared-answer"
ANSWER_SUFFIX = ".answer"
SHARED_FROM = 64 * 1024
"""Binary request bodies of this many bytes or more go through shared memory (smaller ones
cost more in file operations than they save in copies)."""
IOV_MAX = 512  # buffers per writev call (Linux allows 1024)


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


class Segment:
    """One request's segment: create it with `Segment.create`, `release()` it always."""

    def __init__(self, directory: int, fd: int, name: str) -> None:
        self._directory, self._fd, self.name = directory, fd, name

    @classmethod
    def create(cls, directory: str, parts: Sequence[bytes | memoryview]) -> Segment | None:
        """A locked segment holding the body `parts`, in `directory`; None when it cannot
        be made there (no such private directory, no room): the body then goes through
        the socket."""
        dir_fd = _private_directory(directory)
        if dir_fd is None:
            return None
        name = "r-" + secrets.token_hex(16)
        temporary = f".{name}.tmp"
        flags = os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
        try:
            fd = os.open(temporary, flags, 0o600, dir_fd=dir_fd)
        except OSError:
            os.close(dir_fd)
            return None
        try:
            fcntl.flock(fd, fcntl.LOCK_SH)  # held until `release`, or the process ends
            _write_all(fd, parts)
            os.rename(temporary, name, src_dir_fd=dir_fd, dst_dir_fd=dir_fd)
        except OSError:
            with contextlib.suppress(OSError):
                os.unlink(temporary, dir_fd=dir_fd)
            os.close(fd)
            os.close(dir_fd)
            return None
        return cls(dir_fd, fd, name)

    def answer(self, name: str, status: int) -> mmap.mmap:
        """The answer the server wrote into `name`, mapped copy-on-write; the file is removed
        (the mapping stays)."""
        if name != self.name + ANSWER_SUFFIX:
            raise ResponseFormatError(
                f"the server named {name[:80]!r} as the answer to segment {self.name}",
                status=status,
            )
        try:
            fd = os.open(name, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC, dir_fd=self._directory)
        except OSError as exc:
            raise ResponseFormatError(
                f"the answer segment {name} cannot be opened ({exc.strerror})", status=status
            ) from None
        try:
            info = os.fstat(fd)
            if (
                not stat.S_ISREG(info.st_mode)
                or info.st_uid != os.geteuid()
                or stat.S_IMODE(info.st_mode) & 0o077
                or info.st_size < 8
            ):
                raise ResponseFormatError(
                    f"the answer segment {name} is not a private file of this user holding "
                    "an answer",
                    status=status,
                )
            return mmap.mmap(
                fd, info.st_size, flags=mmap.MAP_PRIVATE, prot=mmap.PROT_READ | mmap.PROT_WRITE
            )
        finally:
            os.close(fd)
            with contextlib.suppress(OSError):
                os.unlink(name, dir_fd=self._directory)

    def release(self) -> None:
        """Remove the segment and its answer (if any), and let the lock go."""
        if self._fd < 0:
            return
        for each in (self.name + ANSWER_SUFFIX, self.name):
            with contextlib.suppress(OSError):
                os.unlink(each, dir_fd=self._directory)
        os.close(self._fd)
        os.close(self._directory)
        self._fd = -1


def _write_all(fd: int, parts: Sequence[bytes | memoryview]) -> None:
    """Write `parts` to `fd` one after the other (writev, whatever it writes at a time)."""
    pending = [memoryview(p).cast("B") for p in parts if len(p)]
    while pending:
        written = os.writev(fd, pending[:IOV_MAX])
        while written:
            if written >= len(pending[0]):
                written -= len(pending.pop(0))
            else:
                pending[0] = pending[0][written:]
                written = 0
