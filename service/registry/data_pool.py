"""Idle `pin.Data` kept between computations, within one memory budget for the whole process.

A `pin.Data` is big for big robots (its memory grows with nv³: about 80·nv³ bytes, 170 MB at
nv = 128) and creating one costs time, so each robot keeps the Datas its computations return
(and its OpenMP `ModelPool`) for the next ones. Kept forever, that would grow with every upload;
here every robot's idle Datas count against one budget (`ROBODYN_DATA_POOL_MB`). Returning a
Data that does not fit drops the idle Datas of the least recently used other robots first, and
the returned one itself when that is not enough; a robot's next computation then creates a new
Data. Datas in use are never dropped: their number is bounded by the requests in flight (one on
the event loop, `ROBODYN_MAX_PENDING_BATCHES` in worker threads).
"""

from __future__ import annotations

import threading
from collections import OrderedDict, deque
from typing import Any


def data_bytes(nv: int) -> int:
    """An upper estimate of the memory of one `pin.Data` of a model with nv velocity
    coordinates, in bytes (measured: 33 MB at nv = 101, 90–170 MB at nv = 128)."""
    return 80 * nv**3 + 100_000


class Pool:
    """One robot's idle Datas (and its OpenMP ModelPool), counted against a `Budget`."""

    def __init__(self, budget: Budget, nv: int) -> None:
        self.budget = budget
        self.size = data_bytes(nv)
        self.idle: deque[Any] = deque()
        self.model_pool: Any = None  # pin.ModelPool, created on the first parallel batch
        self.model_pool_size = 0

    def take(self) -> Any | None:
        """An idle Data, or None (then the caller creates one)."""
        return self.budget.take(self)

    def give(self, data: Any) -> None:
        """Return a Data after use: kept if the budget allows, else dropped."""
        self.budget.give(self, data)

    def close(self) -> None:
        """Drop every idle Data (the robot is gone)."""
        self.budget.forget(self)


class Budget:
    """Bytes of idle Datas across all robots, at most `limit_bytes`; least recently used
    robots give theirs up first. Thread-safe (one lock, held for microseconds)."""

    def __init__(self, limit_bytes: int) -> None:
        self.limit_bytes = limit_bytes
        self.idle_bytes = 0
        self._lock = threading.Lock()
        self._recent: OrderedDict[Pool, None] = OrderedDict()  # least recently used first

    def take(self, pool: Pool) -> Any | None:
        with self._lock:
            if not pool.idle:
                return None
            self.idle_bytes -= pool.size
            return pool.idle.pop()

    def give(self, pool: Pool, data: Any) -> None:
        with self._lock:
            self._recent[pool] = None
            self._recent.move_to_end(pool)
            if self._make_room(pool.size, keep=pool):
                pool.idle.append(data)
                self.idle_bytes += pool.size

    def keep_model_pool(self, pool: Pool, model_pool: Any, size: int) -> None:
        """After a parallel batch: keep `model_pool` (`size` bytes) as `pool.model_pool` if
        room can be made as for Datas, else drop it."""
        with self._lock:
            if pool.model_pool is model_pool:
                return  # kept and counted already
            self._recent[pool] = None
            self._recent.move_to_end(pool)
            if self._make_room(size, keep=pool):
                pool.model_pool, pool.model_pool_size = model_pool, size
                self.idle_bytes += size

    def forget(self, pool: Pool) -> None:
        with self._lock:
            self.idle_bytes -= pool.size * len(pool.idle) + pool.model_pool_size
            pool.idle.clear()
            pool.model_pool, pool.model_pool_size = None, 0
            self._recent.pop(pool, None)

    def _make_room(self, size: int, keep: Pool) -> bool:
        """Drop idle Datas and ModelPools of other robots, least recently used first, until
        `size` more bytes fit. Called with the lock held."""
        if self.idle_bytes + size <= self.limit_bytes:
            return True  # the usual case: no list of robots to walk
        if size > self.limit_bytes:
            return False  # would never fit: leave the others alone
        for other in list(self._recent):
            if self.idle_bytes + size <= self.limit_bytes:
                break
            if other is keep:
                continue
            while other.idle and self.idle_bytes + size > self.limit_bytes:
                other.idle.pop()
                self.idle_bytes -= other.size
            if other.model_pool_size and self.idle_bytes + size > self.limit_bytes:
                other.model_pool, self.idle_bytes = None, self.idle_bytes - other.model_pool_size
                other.model_pool_size = 0
            if not other.idle and not other.model_pool_size:
                del self._recent[other]
        return self.idle_bytes + size <= self.limit_bytes


BUDGET = Budget(1024 * 1024 * 1024)
"""The process's budget; `create_app` sets its limit from `ROBODYN_DATA_POOL_MB`."""
