"""Memory for large binary answers, reused once the caller's arrays of an answer are gone.

A large answer is copied into memory of the caller's (from the socket, or from the server's
answer file in shared memory), and its arrays are views of that memory. Memory the process
has not touched yet costs a page fault per 4 kB page on its first write: 1.3–2.5 ms for the
3 MB of 10,000 Talos torques on the 2-core test machine, as long as the copy itself takes
warm (0.3 ms); and the C library's allocator hands out a large block of the size of the one
just freed as new memory again. So the client keeps the memory of an answer whose arrays have
all been collected (the arrays' base is an owner object, and a finalizer on it gives the
memory back: never while any array, view or buffer of the answer is alive) and copies the
next answer of about that size into it. At most `KEPT` blocks wait for reuse; answers kept
by the caller simply take new memory.
"""

from __future__ import annotations

import collections
import weakref
from typing import Any

import numpy as np

KEPT = 2  # free blocks kept for reuse
SMALLEST = 64 * 1024  # smaller answers take new memory (the allocator reuses those itself)


class _Owner:
    """The base of an answer's arrays: numpy reads the block's address from
    `__array_interface__`, and every view of the answer keeps this object alive."""

    __slots__ = ("__array_interface__", "__weakref__")

    def __init__(self, block: np.ndarray, size: int) -> None:
        self.__array_interface__: dict[str, Any] = {
            "shape": (size,),
            "typestr": "|u1",
            "data": (block.ctypes.data, False),
            "version": 3,
        }


class AnswerMemory:
    """Blocks of memory for answers of one client, reused (`take`)."""

    def __init__(self) -> None:
        # (appended by finalizers, which may run in any thread at any allocation: a deque's
        # append and pop need no lock, so none is taken that a finalizer could wait for)
        self._free: collections.deque[np.ndarray] = collections.deque()

    def take(self, size: int) -> memoryview:
        """`size` bytes of writable memory (not zeroed): a free block of about that size
        when there is one, else new."""
        if size < SMALLEST:
            return memoryview(bytearray(size))
        block = self._reuse(size)
        if block is None:
            block = np.empty(size, dtype=np.uint8)
        owner = _Owner(block, size)
        weakref.finalize(owner, _give_back, self._free, block).atexit = False
        return np.asarray(owner).data

    def clear(self) -> None:
        """Drop the free blocks (the client is closing)."""
        self._free.clear()

    def _reuse(self, size: int) -> np.ndarray | None:
        for _ in range(len(self._free)):
            try:
                block = self._free.popleft()
            except IndexError:
                return None
            if size <= block.size <= 2 * size:
                return block
            self._free.append(block)  # (for an answer of another size)
        return None


def _give_back(free: collections.deque[np.ndarray], block: np.ndarray) -> None:
    free.append(block)
    while len(free) > KEPT:
        try:
            free.popleft()
        except IndexError:
            return
