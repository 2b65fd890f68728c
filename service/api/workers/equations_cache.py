"""The equations of each robot, derived once: in memory, and on disk for stored models.

`EquationsCache.answer(robot)` gives the JSON answer of `GET /v1/robots/{id}/equations`:

- from memory (a dict of JSON bytes, least recently used dropped beyond `max_bytes`);
- else, for a stored upload or reduced model (content-derived ids: the same id is the same
  model on every replica and after a restart), from `<data_dir>/equations/v1/<id>.json`;
- else derived in a child process (`derive_isolated`, `service.api.workers.equations`) within
  the time limit, then kept in memory and, for a stored model, written there atomically.
  Catalog robots are kept in memory only (the installed catalog may change between versions).

A model out of scope is refused in this process before any child starts (the check is cheap),
and that refusal is remembered like an answer. Concurrent requests for the same robot wait for
one derivation (single flight); at most `slots` derivations of different robots run at once
(`service.registry.build_slots.BuildSlots`: beyond, 503 overloaded). Blocking: call it off the
event loop. A deleted upload's file stays behind harmlessly: an upload with the same id is the
same model.
"""

from __future__ import annotations

import logging
import threading
from collections import OrderedDict
from concurrent.futures import Future
from pathlib import Path

from service.api.workers.equations import MEMORY_MB, derive_isolated
from service.dynamics.equations.model_numbers import moving_joints
from service.errors import UnsupportedModel
from service.registry.build_slots import BuildSlots
from service.registry.robot import Robot
from service.registry.store import write_atomically

log = logging.getLogger("robodyn.equations")

FORMAT_VERSION = "v1"  # the directory of the files on disk; a new answer format gets a new one


class EquationsCache:
    """See the module docstring. `time_limit_s` bounds one derivation."""

    def __init__(
        self,
        data_dir: Path | None,
        time_limit_s: float,
        slots: BuildSlots,
        max_bytes: int = 256 * 1024 * 1024,
        memory_mb: int = MEMORY_MB,
    ) -> None:
        self.dir = None if data_dir is None else Path(data_dir) / "equations" / FORMAT_VERSION
        self.time_limit_s = time_limit_s
        self.memory_mb = memory_mb
        self.slots = slots
        self.max_bytes = max_bytes
        self._memory: OrderedDict[str, bytes] = OrderedDict()
        self._bytes = 0
        self._refused: dict[str, UnsupportedModel] = {}
        self._pending: dict[str, Future[bytes]] = {}
        self._lock = threading.Lock()

    def _path(self, robot: Robot) -> Path | None:
        if self.dir is None or robot.source == "catalog":
            return None
        return self.dir / f"{robot.id}.json"

    def _remember(self, key: str, body: bytes) -> None:
        with self._lock:
            if key in self._memory:
                return
            self._memory[key] = body
            self._bytes += len(body)
            while self._bytes > self.max_bytes and len(self._memory) > 1:
                _, dropped = self._memory.popitem(last=False)
                self._bytes -= len(dropped)

    def cached(self, robot: Robot) -> bytes | None:
        """The answer when it is in memory (no disk, no derivation); refusals raise."""
        with self._lock:
            refused = self._refused.get(robot.id)
            if refused is not None:
                raise UnsupportedModel(refused.detail)
            body = self._memory.get(robot.id)
            if body is not None:
                self._memory.move_to_end(robot.id)
            return body

    def answer(self, robot: Robot) -> bytes:
        """The JSON answer for `robot` (see the module docstring)."""
        body = self.cached(robot)
        if body is not None:
            return body
        try:
            moving_joints(robot.model)
        except UnsupportedModel as exc:
            with self._lock:
                self._refused[robot.id] = exc
            raise
        path = self._path(robot)
        if path is not None and path.is_file():
            try:
                body = path.read_bytes()
            except OSError as exc:
                log.warning("equations of %s not read from disk: %s", robot.id, exc)
            else:
                self._remember(robot.id, body)
                return body
        with self._lock:
            pending = self._pending.get(robot.id)
            owner = pending is None
            if pending is None:
                pending = self._pending[robot.id] = Future()
        if not owner:
            return pending.result()
        try:
            with self.slots.slot():
                body = derive_isolated(robot.model, self.time_limit_s, self.memory_mb)
        except UnsupportedModel as exc:
            with self._lock:
                self._refused[robot.id] = exc
                del self._pending[robot.id]
            pending.set_exception(exc)
            raise
        except BaseException as exc:
            with self._lock:
                del self._pending[robot.id]
            pending.set_exception(exc)
            raise
        self._remember(robot.id, body)
        with self._lock:
            del self._pending[robot.id]
        pending.set_result(body)
        if path is not None:
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                write_atomically(path, body)
            except OSError as exc:  # a read-only or full disk: the memory copy serves
                log.warning("equations of %s not written to disk: %s", robot.id, exc)
        return body
