"""One request's shared-memory segments on the service's side (see `service.segments`).

    segment = RequestSegment(directory, name, length, max_bytes, room)  # the body, mapped
    ... decode and compute from segment.body (a read-only view of `length` bytes) ...
    segment.answer_arrays(shapes) # optional: the answer's arrays, in the answer's file
    segment.write_answer(parts)   # into the client's room, or an answer file of the service
    segment.end()                 # always, when the request ends

The answer goes into the client's answer room when the request names one (`room`: the client
linked a file of its own, `c-<32 hex>`, as `<name>.answer`): the client then hands its caller
arrays of that file, no copy made. Otherwise (and whenever the room cannot take the answer: it
cannot grow) it goes into an answer file of this process, linked as `<name>.answer` in the
room's place.

Who removes what, when: the client removes the request's names (`<name>`, `<name>.answer`)
once it has copied the answer out (or met an error), keeping its body file for its next
request. `end()` removes them when the client no longer holds its lock (killed mid-request, or
gone before the answer); if the client dies after `end()`, the sweeper of `SegmentDirectory`
does. The service checks what it maps: a regular file (not a link) of its own user, readable by
no one else, holding at least `length` bytes, `length` at most `max_bytes`; a room alike,
and locked by its client (no file the client does not hold). Whoever can reach the socket and
the directory is the service's own user: they are trusted not to shrink a file the service is
reading or writing (a mapping's pages then fault, and the process ends).
"""

from __future__ import annotations

import contextlib
import math
import mmap
import os
import stat
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from service.segments.answer_pool import AnswerFile, write_views
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


@dataclass
class _Reserved:
    """The answer's arrays (`answer_arrays`), in `mapping`: of the client's room (`file`
    None) or of an answer file of this process, taken from the pool until the answer is
    written."""

    mapping: mmap.mmap
    arrays: list[np.ndarray]
    file: AnswerFile | None


class RequestSegment:
    """The first `length` bytes of the segment `name` of `directory`, as a client wrote them:
    `body` (a read-only view of a mapping of the file, or b"" when empty). `room`: the name
    of the client's answer room, as the request gives it (`<name>.answer`), or None."""

    def __init__(
        self,
        directory: SegmentDirectory,
        name: str,
        length: int,
        max_bytes: int,
        room: str | None = None,
    ) -> None:
        if not NAME.fullmatch(name):
            raise SegmentError(
                f"{name[:80]!r} is not a segment name ('r-' and 32 lower-case hex digits)"
            )
        if length > max_bytes:
            raise SegmentTooLarge(length, max_bytes)
        if room is not None and room != name + ANSWER_SUFFIX:
            raise SegmentError(
                f"Robodyn-Shared-Room must name {name + ANSWER_SUFFIX}, the answer of the "
                "request's segment"
            )
        self.directory, self.name, self.length = directory, name, length
        self.answer: str | None = None  # the value of Robodyn-Shared-Answer, once written
        self._reserved: _Reserved | None = None  # answer_arrays
        self._room_fd = -1
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
            if length:  # (kept mapped for the client's next request: client_mappings.py)
                self.body = memoryview(directory.bodies.map(self._fd, info, length))[:length]
            if room is not None:
                self._room_fd = _open_room(directory, room)
        except BaseException:
            os.close(self._fd)
            raise

    def answer_arrays(self, shapes: Mapping[str, tuple[int, ...]]) -> dict[str, np.ndarray] | None:
        """Float64 arrays of `shapes` (C order, one after the other) in the client's room, or
        else in a free answer file of this process, after `HEADER_ROOM` bytes left for the
        header: an answer computed into them is written with its header only
        (`write_answer`). Once per request; None when there is no file to spare or it cannot
        grow (the answer is then made in new memory and copied)."""
        if self._reserved is not None:
            return None
        sizes = [8 * math.prod(shape) for shape in shapes.values()]
        needed = HEADER_ROOM + sum(sizes)
        file = None
        if self._room_fd >= 0:
            mapping = self._room_mapping(needed)
            if mapping is None:
                return None
        else:
            file = self.directory.answers.take(needed)
            if file is None:
                return None
            try:
                mapping = file.reserve(needed)
            except OSError:  # (no room: the answer is made in new memory, and copied)
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
        self._reserved = _Reserved(mapping, list(arrays.values()), file)
        return arrays

    def _room_mapping(self, needed: int) -> mmap.mmap | None:
        """The client's room grown to `needed` bytes, mapped for writing (kept mapped for the
        client's next requests: client_mappings.py); None when it cannot grow."""
        try:
            info = os.fstat(self._room_fd)
            if info.st_size < needed:
                os.posix_fallocate(self._room_fd, 0, needed)
                info = os.fstat(self._room_fd)
        except OSError:
            return None
        return self.directory.rooms.map(self._room_fd, info, needed)

    def holds_answer(self, arrays: Sequence[np.ndarray]) -> bool:
        """Whether `arrays` are the arrays `answer_arrays` gave, whole and in order: their
        answer is then written as its header alone (a few microseconds)."""
        if self._reserved is None or len(arrays) != len(self._reserved.arrays):
            return False
        return all(
            a.nbytes == r.nbytes and a.ctypes.data == r.ctypes.data
            for a, r in zip(arrays, self._reserved.arrays, strict=True)
        )

    def write_answer(self, parts: Sequence[bytes | memoryview]) -> str:
        """Write an answer (its parts one after the other: the header, then each array's
        bytes) as `<name>.answer`: arrays already in the client's room or in an answer file
        (`answer_arrays`), in order and whole, are not copied (the header is written before
        them, padded to `HEADER_ROOM`); any other answer is copied into the client's room, or
        (without one, when it cannot grow, or when the parts view arrays reserved in it) into
        a free answer file of this process (or a new file of its own), linked in the room's
        place. The value of the answer's `Robodyn-Shared-Answer`: that name and the answer's
        length in bytes."""
        reserved, self._reserved = self._reserved, None
        try:
            if reserved is not None:
                head = _header_in_place(parts, reserved.arrays)
                if head is not None:
                    return self._write_header(reserved, head)
            # (never copied over the reserved arrays the parts may view: those in the room
            # go into a file of this process, and a reserved file stays taken meanwhile)
            if self._room_fd >= 0 and (reserved is None or reserved.file is not None):
                answer = self._copy_into_room(parts)
                if answer is not None:
                    return answer
            self._close_room()
            return self._copy_answer(parts)
        finally:
            if reserved is not None and reserved.file is not None:
                self.directory.answers.give(reserved.file)

    def _write_header(self, reserved: _Reserved, head: bytes) -> str:
        name = self.name + ANSWER_SUFFIX
        reserved.mapping[:HEADER_ROOM] = head
        if reserved.file is not None:  # (a room is linked there by its client already)
            os.link(self.directory.path / reserved.file.name, self.directory.path / name)
        self.answer = f"{name} {HEADER_ROOM + sum(a.nbytes for a in reserved.arrays)}"
        return self.answer

    def _copy_into_room(self, parts: Sequence[bytes | memoryview]) -> str | None:
        """Copy an answer into the client's room; None when the room cannot grow to it."""
        views = [memoryview(p).cast("B") for p in parts if len(p)]
        size = sum(len(v) for v in views)
        mapping = self._room_mapping(size)
        if mapping is None:
            return None
        write_views(mapping, views)
        self.answer = f"{self.name + ANSWER_SUFFIX} {size}"
        return self.answer

    def _copy_answer(self, parts: Sequence[bytes | memoryview]) -> str:
        name = self.name + ANSWER_SUFFIX
        path = self.directory.path
        with contextlib.suppress(FileNotFoundError):  # (a room that does not take this answer)
            os.unlink(path / name)
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
            if self._reserved.file is not None:
                self.directory.answers.give(self._reserved.file)
            self._reserved = None
        self._close_room()
        if self._fd < 0:
            return
        os.close(self._fd)
        self._fd = -1
        # Tested on a description of its own: a lock taken through `_fd` would last as long
        # as the kept mapping's duplicate of it.
        if not held(self.directory.path / self.name):
            self.directory.remove(self.name)  # (a client still there removes them itself)

    def _close_room(self) -> None:
        if self._room_fd >= 0:
            os.close(self._room_fd)
            self._room_fd = -1


def _open_room(directory: SegmentDirectory, room: str) -> int:
    """A descriptor, open for writing, of the client's answer room linked as `room`: a regular
    file of the service's user, mode 0600, that a client holds locked (never a file of the
    service's own, nor one nobody holds)."""
    flags = os.O_RDWR | os.O_NOFOLLOW | os.O_CLOEXEC | os.O_NONBLOCK
    try:
        fd = os.open(directory.path / room, flags)
    except OSError as exc:
        raise SegmentError(
            f"the answer room named by the request cannot be opened ({exc.strerror})"
        ) from None
    try:
        info = os.fstat(fd)
        if (
            not stat.S_ISREG(info.st_mode)
            or info.st_uid != os.geteuid()
            or stat.S_IMODE(info.st_mode) & 0o077
            or directory.answers.owns(info)
            or not held(directory.path / room)
        ):
            raise SegmentError(
                "the answer room is not a regular file of the service's user, readable by no "
                "one else (mode 0600) and locked by its client"
            )
    except BaseException:
        os.close(fd)
        raise
    return fd


def _header_in_place(parts: Sequence[bytes | memoryview], arrays: list[np.ndarray]) -> bytes | None:
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
