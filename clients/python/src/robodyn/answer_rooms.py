"""Answer rooms of a co-located client: files of its own (`c-<32 hex>`, locked like its body
files) into which the server writes the answers, lent to the caller without a copy.

A request through shared memory links a free room as its answer name (`r-<32 hex>.answer`) and
names it in `Robodyn-Shared-Room`; the server writes the answer there (growing the file as
needed). The caller's arrays then view the room's mapping: no copy of the answer is made (about
0.5 ms for the 3 MB of 10,000 Talos torques on the 2-core machine), and the room serves no
other request until every array and view of that answer is gone (a finalizer on their base
gives it back). At most `MAX_ROOMS` rooms are kept; while all are lent, a request offers none
and its answer is copied out of a file of the server's. A room whose request did not end with
its answer read whole (a timeout: the server may still write into it) is closed for good.
"""

from __future__ import annotations

import collections
import mmap
import os
import threading
import weakref
from typing import Any

import numpy as np

from robodyn.client_files import ClientFile
from robodyn.errors import ResponseFormatError

MAX_ROOMS = 4
"""Answer rooms a client keeps: the answers in them are its caller's arrays, no copy made
(about 0.5 ms for 3 MB); while the arrays of `MAX_ROOMS` answers are alive, answers are copied
out of the server's files instead (a caller who keeps every answer does not keep a file of
shared memory for each)."""


class AnswerRooms:
    """The answer rooms of one client in its server's segment directory `directory`."""

    def __init__(self, directory: str) -> None:
        self.directory = directory
        self._lock = threading.Lock()
        # every room the client has (`_rooms`), and those free for a request (`_free`: a
        # deque, appended by finalizers, which may run in any thread at any allocation, so
        # without a lock they could wait for)
        self._rooms: set[ClientFile] = set()
        self._free: collections.deque[ClientFile] = collections.deque()
        self._closed = False

    def take(self, answer_name: str) -> ClientFile | None:
        """A free answer room (or a new one, below `MAX_ROOMS`) linked as `answer_name`; None
        when every room is lent, or none can be made."""
        try:
            room = self._free.popleft()
        except IndexError:
            with self._lock:
                if len(self._rooms) >= MAX_ROOMS:
                    return None
                made = ClientFile.create(self.directory)
                if made is None:
                    return None
                self._rooms.add(made)
            room = made
        try:
            os.link(
                room.name,
                answer_name,
                src_dir_fd=room.directory,
                dst_dir_fd=room.directory,
            )
        except OSError:
            self.discard(room)
            return None
        return room

    def lend(self, room: ClientFile, size: int, status: int) -> memoryview:
        """The first `size` bytes of the answer room `room`, lent to the caller: a writable
        view whose base (kept alive by every array and view of the answer) gives the room
        back once collected."""
        mapping = self._room_mapping(room, size)
        if mapping is None:
            self.discard(room)
            raise ResponseFormatError(
                f"the answer room holds fewer than the {size} bytes of the answer", status=status
            )
        owner = _Lent(np.frombuffer(mapping, dtype=np.uint8, count=size))
        weakref.finalize(owner, self.give, room).atexit = False
        return np.asarray(owner).data

    def _room_mapping(self, room: ClientFile, size: int) -> mmap.mmap | None:
        try:
            return room.mapped(size)
        except OSError:
            return None

    def give(self, room: ClientFile) -> None:
        """A room back for the next requests (also from the finalizer of a lent answer: no
        lock taken); closed when the client is."""
        if self._closed:
            room.close()
        else:
            self._free.append(room)

    def discard(self, room: ClientFile) -> None:
        """Close the room `room` for good (the server may still write into it)."""
        with self._lock:
            self._rooms.discard(room)
        room.close()

    def close(self) -> None:
        """Close the free rooms now, and the lent ones once their answers are collected (their
        memory stays valid until then)."""
        self._closed = True
        while True:
            try:
                self._free.popleft().close()
            except IndexError:
                return


class _Lent:
    """The base of an answer lent from a room: numpy reads its address from
    `__array_interface__`, and holding `view` keeps the room's mapping mapped."""

    __slots__ = ("__array_interface__", "__weakref__", "view")

    def __init__(self, view: np.ndarray) -> None:
        self.view = view
        self.__array_interface__: dict[str, Any] = {
            "shape": view.shape,
            "typestr": "|u1",
            "data": (view.ctypes.data, False),
            "version": 3,
        }
