"""One request's shared-memory segments on the service's side (see `service.segments`).

    segment = RequestSegment(directory, name, length, max_bytes)  # the client's body, mapped
    ... decode and compute from segment.body (a read-only view of `length` bytes) ...
    segment.answer_arrays(shapes) # optional: the answer's arrays, in an answer file
    segment.write_answer(parts)   # into an answer file, linked as <name>.answer
    segment.end()                 # always, when the request ends

Who removes what, when: the client removes the request's names (`<name>`, `<name>.answer`)
once it has copied the answer out (or met an error), keeping its body file for its next
request. `end()` removes them when the client no longer holds its lock (killed mid-request, or
gone before the answer); if the client dies after `end()`, the sweeper of `SegmentDirectory`
does. The service checks what it maps: a regular file (not a link) of its own user, readable by
no one else, holding at least `length` bytes, `length` at most `max_bytes`.
"""

from __future__ import annotations

import math
import os
import stat
import struct
from collections.abc import Mapping, Sequence

import numpy as np

from service.segments.answer_pool import AnswerFile
from service.segments.directory import ANSWER_SUFFIX, NAME, SegmentDirectory, held

IOV_MAX = 512  # buffers per writev call (Linux allows 1024)
HEADER_ROOM = 4096  # bytes before an answer computed in place (`answer_arrays`): its header


class SegmentError(Exception):
    """A request's segment cannot be used; the message says why (and names no path)."""


class SegmentTooLarge(SegmentError):
    """A body over the body limit: `size` bytes."""

    def __init__(self, size: int, limit: int) -> None:
        super().__init__(f"the shared-memory body has {size} bytes; the limit is {limit}")
        self.size, self.limit = size, limit


class RequestSegment:
    """The first `length` bytes of the segment `name` of `directory`, as a client wrote them:
    `body` (a read-only view of a mapping of the file, or b"" when empty)."""

    def __init__(self, directory: SegmentDirectory, name: str, length: int, max_bytes: int) -> None:
        if not NAME.fullmatch(name):
            raise SegmentError(
                f"{name[:80]!r} is not a segment name ('r-' and 32 lower-case hex digits)"
            )
        if length > max_bytes:
            raise SegmentTooLarge(length, max_bytes)
        self.directory, self.name, self.length = directory, name, length
        self.answer: str | None = None  # the value of Robodyn-Shared-Answer, once written
        self._reserved: tuple[AnswerFile, list[np.ndarray]] | None = None  # answer_arrays
        self.body: memoryview | bytes = b""
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
            if info.st_size < length:
                raise SegmentError(
                    f"the shared-memory segment holds {info.st_size} bytes, fewer than the "
                    f"{length} the request names"
                )
            if length:  # (kept mapped for the client's next request: body_mappings.py)
                self.body = memoryview(directory.bodies.map(self._fd, info, length))[:length]
        except BaseException:
            os.close(self._fd)
            raise

    def answer_arrays(self, shapes: Mapping[str, tuple[int, ...]]) -> dict[str, np.ndarray] | None:
        """Float64 arrays of `shapes` (C order, one after the other) in a free answer file of
        this process, after `HEADER_ROOM` bytes left for the header: an answer computed into
        them is written with its header only (`write_answer`). Once per request; None when
        the pool has no file to spare (the answer is then made in new memory and copied)."""
        if self._reserved is not None:
            return None
        sizes = [8 * math.prod(shape) for shape in shapes.values()]
        file = self.directory.answers.take(HEADER_ROOM + sum(sizes))
        if file is None:
            return None
        try:
            mapping = file.reserve(HEADER_ROOM + sum(sizes))
        except OSError:  # (no room: the answer is made in new memory, and copied as it can be)
            self.directory.answers.give(file)
            return None
        except BaseException:
            self.directory.answers.give(file)
            raise
        arrays, offset = {}, HEADER_ROOM
        for (name, shape), size in zip(shapes.items(), sizes, strict=True):
            count = size // 8
            arrays[name] = np.frombuffer(mapping, np.float64, count, offset).reshape(shape)
            offset += size
        self._reserved = (file, list(arrays.values()))
        return arrays

    def holds_answer(self, arrays: Sequence[np.ndarray]) -> bool:
        """Whether `arrays` are the arrays `answer_arrays` gave, whole and in order: their
        answer is then written as its header alone (a few microseconds)."""
        if self._reserved is None or len(arrays) != len(self._reserved[1]):
            return False
        return all(
            a.nbytes == r.nbytes and a.ctypes.data == r.ctypes.data
            for a, r in zip(arrays, self._reserved[1], strict=True)
        )

    def write_answer(self, parts: Sequence[bytes | memoryview]) -> str:
        """Write an answer (its parts one after the other: the header, then each array's
        bytes) into a free answer file of this process (or a new file of its own) linked as
        `<name>.answer`; the value of the answer's `Robodyn-Shared-Answer`: that name and the
        answer's length in bytes. Arrays already in the file (`answer_arrays`), in order and
        whole, are not copied: the header is written before them, padded to `HEADER_ROOM`."""
        reserved, self._reserved = self._reserved, None
        try:
            if reserved is not None:
                head = _in_place(parts, reserved[1])
                if head is not None:
                    return self._link_in_place(reserved, head)
            # (a reserved file stays taken while the parts, which may view it, are copied)
            return self._copy_answer(parts)
        finally:
            if reserved is not None:
                self.directory.answers.give(reserved[0])

    def _link_in_place(self, reserved: tuple[AnswerFile, list[np.ndarray]], head: bytes) -> str:
        file, arrays = reserved
        name = self.name + ANSWER_SUFFIX
        assert file.mapping is not None  # (reserved: mapped)
        file.mapping[:HEADER_ROOM] = head
        os.link(self.directory.path / file.name, self.directory.path / name)
        self.answer = f"{name} {HEADER_ROOM + sum(a.nbytes for a in arrays)}"
        return self.answer

    def _copy_answer(self, parts: Sequence[bytes | memoryview]) -> str:
        name = self.name + ANSWER_SUFFIX
        path = self.directory.path
        pool = self.directory.answers
        views = [memoryview(p).cast("B") for p in parts if len(p)]
        size = sum(len(v) for v in views)
        free = pool.take(size)
        if free is None:
            flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
            fd = os.open(path / name, flags, 0o600)
            try:
                write_all(fd, views)
            except BaseException:
                os.unlink(path / name)
                raise
            finally:
                os.close(fd)
        else:
            try:
                free.write(views)
                os.link(path / free.name, path / name)
            finally:
                pool.give(free)
        self.answer = f"{name} {size}"
        return self.answer

    def end(self) -> None:
        """The request is over, however it ended: let go of the body (its mapping is kept by
        the directory's `bodies`), and remove the request's names when their client no
        longer holds its lock (it is gone)."""
        self.body = b""
        if self._reserved is not None:  # (arrays reserved for an answer never written)
            self.directory.answers.give(self._reserved[0])
            self._reserved = None
        if self._fd < 0:
            return
        os.close(self._fd)
        self._fd = -1
        # Tested on a description of its own: a lock taken through `_fd` would last as long
        # as the kept mapping's duplicate of it.
        if not held(self.directory.path / self.name):
            self.directory.remove(self.name)  # (a client still there removes them itself)


def _in_place(parts: Sequence[bytes | memoryview], arrays: list[np.ndarray]) -> bytes | None:
    """The first `HEADER_ROOM` bytes of an answer whose `parts` (a safetensors header, then
    each array's bytes) are `arrays` whole and in order: the header, its JSON padded with
    spaces; None when they are not, or the header does not fit."""
    head, *data = parts
    if len(data) != len(arrays) or len(head) > HEADER_ROOM:
        return None
    for part, array in zip(data, arrays, strict=True):
        view = np.frombuffer(part, np.uint8)
        if view.size != array.nbytes or view.ctypes.data != array.ctypes.data:
            return None
    text = bytes(head[8:]).rstrip(b" ")
    return struct.pack("<Q", HEADER_ROOM - 8) + text + b" " * (HEADER_ROOM - 8 - len(text))


def write_all(fd: int, views: Sequence[memoryview], offset: int = 0) -> None:
    """Write `views` (bytes) one after the other into `fd` from `offset` (pwritev, whatever
    it writes at a time)."""
    pending = [v for v in views if len(v)]
    while pending:
        written = os.pwritev(fd, pending[:IOV_MAX], offset)
        offset += written
        while written:
            if written >= len(pending[0]):
                written -= len(pending.pop(0))
            else:
                pending[0] = pending[0][written:]
                written = 0
