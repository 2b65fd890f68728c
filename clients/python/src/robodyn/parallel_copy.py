"""Copies of large bodies and answers on two threads: a copy of megabytes is bound by memory,
and two cores move more bytes at once than one (9.2 MB into shared memory: 0.67–0.89 ms
against 0.87–1.1 on the 2-core test machine, caches cold). numpy's copy releases the GIL, so
the second half runs in a helper thread while this one copies the first."""

from __future__ import annotations

import os
import threading
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

TWO_THREADS_FROM = 2 * 1024 * 1024  # bytes: smaller copies take one thread (a wake-up costs more)

_helper: tuple[int, ThreadPoolExecutor] | None = None  # (the process it belongs to, the pool)
_helper_lock = threading.Lock()


def _second_thread() -> ThreadPoolExecutor:
    """The helper thread of this process (made anew in a forked child, where the parent's
    thread does not run)."""
    global _helper
    with _helper_lock:
        if _helper is None or _helper[0] != os.getpid():
            _helper = (os.getpid(), ThreadPoolExecutor(1, thread_name_prefix="robodyn-copy"))
        return _helper[1]


def copy_into(destination: np.ndarray, views: Sequence[memoryview]) -> None:
    """Copy `views` (bytes, 1-D) one after the other into the uint8 array `destination` from
    its start (which holds at least their total length)."""
    total = sum(len(v) for v in views)
    if total < TWO_THREADS_FROM:
        _copy(destination, views, 0, total)
        return
    half = total // 2
    pending = _second_thread().submit(_copy, destination, views, half, total)
    try:
        _copy(destination, views, 0, half)
    finally:
        pending.result()


def _copy(destination: np.ndarray, views: Sequence[memoryview], begin: int, end: int) -> None:
    """Bytes `begin` to `end` of the views laid one after the other, to the same place."""
    offset = 0
    for view in views:
        start, stop = max(begin, offset), min(end, offset + len(view))
        if start < stop:
            source = np.frombuffer(view, dtype=np.uint8, count=stop - start, offset=start - offset)
            destination[start:stop] = source
        offset += len(view)
        if offset >= end:
            return
