"""One request's shared-memory segments on the service's side (see `service.segments`).

    segment = RequestSegment(directory, name, max_bytes)   # the client's body, mapped
    ... decode and compute from segment.body (a read-only mmap) ...
    segment.write_answer(parts)                           # r-<hex>.answer, named in the answer
    segment.end()                                         # always, when the request ends

Who removes what, when: the client removes both files once it has read the answer (or met an
error), then releases its lock. `end()` removes them when the client no longer holds its lock
(killed mid-request, or gone before the answer); if the client dies after `end()`, the sweeper
of `SegmentDirectory` does. The service checks what it maps: a regular file (not a link) of its
own user, readable by no one else, at most `max_bytes` long.
"""

from __future__ import annotations

import contextlib
import fcntl
import mmap
import os
import stat
from collections.abc import Sequence

from service.segments.directory import ANSWER_SUFFIX, NAME, SegmentDirectory

IOV_MAX = 512  # buffers per writev call (Linux allows 1024)


class SegmentError(Exception):
    """A request's segment cannot be used; the message says why (and names no path)."""


class SegmentTooLarge(SegmentError):
    """A segment over the body limit: `size` bytes."""

    def __init__(self, size: int, limit: int) -> None:
        super().__init__(f"the shared-memory segment has {size} bytes; the limit is {limit}")
        self.size, self.limit = size, limit


class RequestSegment:
    """The segment `name` of `directory`, as a client wrote it: `body` is its content (a
    read-only mmap, or b"" when empty), `size` its length in bytes."""

    def __init__(self, directory: SegmentDirectory, name: str, max_bytes: int) -> None:
        if not NAME.fullmatch(name):
            raise SegmentError(
                f"{name[:80]!r} is not a segment name ('r-' and 32 lower-case hex digits)"
            )
        self.directory, self.name = directory, name
        self.answer_name: str | None = None
        self.body: mmap.mmap | bytes = b""
        flags = os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC | os.O_NONBLOCK
        try:
            self._fd = os.open(directory.path / name, flags)
        except FileNotFoundError:
            raise SegmentError(
                "the shared-memory segment named by the request does not exist (a client "
                "on this host writes it into the segment directory beside the socket)"
            ) from None
        except OSError as exc:
            raise SegmentError(
                f"the shared-memory segment cannot be opened ({exc.strerror})"
            ) from None
        try:
            info = os.fstat(self._fd)
            if (
                not stat.S_ISREG(info.st_mode)
                or info.st_uid != os.geteuid()
                or stat.S_IMODE(info.st_mode) & 0o077
            ):
                raise SegmentError(
                    "the shared-memory segment is not a regular file of the service's user "
                    "readable by no one else (mode 0600)"
                )
            self.size = info.st_size
            if self.size > max_bytes:
                raise SegmentTooLarge(self.size, max_bytes)
            if self.size:
                self.body = mmap.mmap(self._fd, self.size, access=mmap.ACCESS_READ)
        except BaseException:
            os.close(self._fd)
            raise

    def write_answer(self, parts: Sequence[bytes | memoryview]) -> str:
        """Write an answer (its parts one after the other) into `<name>.answer`, readable
        only by the service's user; its name."""
        name = self.name + ANSWER_SUFFIX
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
        fd = os.open(self.directory.path / name, flags, 0o600)
        try:
            write_all(fd, parts)
        except BaseException:
            os.unlink(self.directory.path / name)
            raise
        finally:
            os.close(fd)
        self.answer_name = name
        return name

    def end(self) -> None:
        """The request is over, however it ended: unmap the body, and remove the segments
        when their client no longer holds its lock (it is gone)."""
        body, self.body = self.body, b""
        if isinstance(body, mmap.mmap):
            # (arrays still viewing it: it is unmapped once they are collected)
            with contextlib.suppress(BufferError):
                body.close()
        if self._fd < 0:
            return
        try:
            try:
                fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                return  # the client is there: it removes them once it has read the answer
            self.directory.remove(self.name)
        finally:
            os.close(self._fd)
            self._fd = -1


def write_all(fd: int, parts: Sequence[bytes | memoryview]) -> None:
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
