"""Binary bodies and answers through shared memory, for a client on the server's Unix socket
(`Client("unix:///path/robodyn.sock")`; the server's docs/binary-format.md, "Through shared
memory").

The server's segment directory is `<socket>.segments` (or where that links to); it must be a
directory of this user that no one else may enter, else bodies go through the socket as usual.
A request in the binary form of `SHARED_FROM` bytes or more is written, instead of sent, into
a body file of the client (`c-<32 hex>`, mode 0600, locked with flock for as long as the client
keeps it, and reused from request to request: its pages are already there), linked under a
name of its own for this request (`r-<32 hex>`) and named, with its length, in the request's
`Robodyn-Shared-Body`. With it the client links an answer room of its own (another locked
`c-<32 hex>` file) as `r-<32 hex>.answer` and names it in `Robodyn-Shared-Room`. The server
maps it, computes, and writes a binary answer into `r-<32 hex>.answer`, named with its length
in the answer's `Robodyn-Shared-Answer`. An answer in the room is lent to the caller without
a copy (`robodyn.answer_rooms`); an answer in a file of the server's (reused for its later
answers, when the client had no free room) is copied out. The client then removes the
request's names. The lock tells the server that the client is still
there: a client killed mid-request leaves files nobody holds, which the server removes.
"""

from __future__ import annotations

import contextlib
import mmap
import os
import secrets
import stat
import threading
from collections.abc import Sequence

import numpy as np

from robodyn.answer_memory import AnswerMemory
from robodyn.answer_rooms import AnswerRooms
from robodyn.client_files import ClientFile, close_quietly
from robodyn.errors import ResponseFormatError
from robodyn.parallel_copy import copy_into

BODY_HEADER = "Robodyn-Shared-Body"
ROOM_HEADER = "Robodyn-Shared-Room"
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


class Segment:
    """One request's body in shared memory: `name` and `length` go in its header, `room` (the
    name of its answer room, or None) in `ROOM_HEADER`; `answer` reads the answer; `release`
    always."""

    def __init__(
        self,
        pool: SharedMemory,
        file: ClientFile,
        name: str,
        length: int,
        room: ClientFile | None = None,
    ) -> None:
        self._pool, self._file, self.name, self.length = pool, file, name, length
        self._room = room
        self.settled = False  # set once the server's answer has been read whole

    @property
    def header(self) -> str:
        return f"{self.name} {self.length}"

    @property
    def room(self) -> str | None:
        return None if self._room is None else self.name + ANSWER_SUFFIX

    def answer(self, value: str, status: int) -> memoryview:
        """The answer named by `Robodyn-Shared-Answer: <name> <length>`: in the answer room,
        the room's own memory, lent to the caller (writable, no copy); in a file of the
        server's, copied out into memory of the caller's (writable). Its name is removed."""
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
            room, self._room = self._room, None
            if room is not None and room.identity == (info.st_dev, info.st_ino):
                os.close(fd)
                fd = -1
                return self._pool.rooms.lend(room, size, status)
            if room is not None:
                self._pool.rooms.give(room)  # (the server wrote the answer elsewhere)
        except BaseException:
            if fd >= 0:
                os.close(fd)
            raise
        finally:
            with contextlib.suppress(OSError):
                os.unlink(name, dir_fd=directory)
        return self._pool.copy_out(fd, info, size)  # (takes the descriptor)

    def release(self) -> None:
        """Remove this request's names (body and answer); the body file is kept for the
        client's next request, and so is the answer room unless its answer was lent, or the
        request did not end with an answer read whole (the server may then still write
        into it: it is closed)."""
        for each in (self.name + ANSWER_SUFFIX, self.name):
            with contextlib.suppress(OSError):
                os.unlink(each, dir_fd=self._file.directory)
        self._pool.give(self._file)
        room, self._room = self._room, None
        if room is not None:
            if self.settled:
                self._pool.rooms.give(room)
            else:
                self._pool.rooms.discard(room)


class SharedMemory:
    """The body files of one client of the Unix socket `socket_path` (one per request in
    flight, `KEPT_FILES` kept idle); `close` removes them."""

    def __init__(self, socket_path: str, memory: AnswerMemory | None = None) -> None:
        self.directory = directory_of(socket_path)
        self._memory = AnswerMemory() if memory is None else memory
        self._idle: list[ClientFile] = []
        self._answers: dict[tuple[int, int], tuple[int, mmap.mmap]] = {}  # oldest first
        self._lock = threading.Lock()
        self.rooms = AnswerRooms(self.directory)

    def segment(self, parts: Sequence[bytes | memoryview]) -> Segment | None:
        """The body `parts` written into a body file, linked under a new request name; None
        when it cannot be (the body then goes through the socket)."""
        with self._lock:
            file = self._idle.pop() if self._idle else None
        if file is None:
            file = ClientFile.create(self.directory)
            if file is None:
                return None
        name = "r-" + secrets.token_hex(16)
        try:
            length = file.write(parts)
            os.link(file.name, name, src_dir_fd=file.directory, dst_dir_fd=file.directory)
        except OSError:
            file.close()  # (gone from under us, or no room: not kept)
            return None
        return Segment(self, file, name, length, self.rooms.take(name + ANSWER_SUFFIX))

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
            copy_into(np.frombuffer(content, dtype=np.uint8), [memoryview(mapping)[:size]])
        return content

    def give(self, file: ClientFile) -> None:
        with self._lock:
            if len(self._idle) < KEPT_FILES:
                self._idle.append(file)
                return
        file.close()

    def close(self) -> None:
        """Remove the client's files: idle body files and free rooms now, rooms lent to
        answers once those are collected (their memory stays valid until then)."""
        with self._lock:
            idle, self._idle = self._idle, []
            answers, self._answers = self._answers, {}
        for file in idle:
            file.close()
        for cached in answers.values():
            _close_mapping(*cached)
        self.rooms.close()


def _close_mapping(fd: int, mapping: mmap.mmap) -> None:
    close_quietly(mapping)
    os.close(fd)
