"""The equations of each robot, derived once: in memory, and on disk for stored models.

`await EquationsCache.answer(robot, printing)` gives the JSON answer of
`GET /v1/robots/{id}/equations` printed as asked (`Printing`: form, digits, tolerance), each
printing of each robot kept on its own:

- from memory (a dict of JSON bytes, least recently used dropped beyond `max_bytes`);
- else, for a stored upload or reduced model (content-derived ids: the same id is the same
  model on every replica and after a restart) printed readable (the defaults) or exact
  (`digits=17&tolerance=0`), from `<data_dir>/equations/v3/<id>/<form>-<digits>-<tolerance>.json`
  (other printings are kept in memory only: a client varying `tolerance` cannot fill the
  disk);
- else derived in a child process (`derive_isolated`, `service.api.workers.equations`) within
  the time limit, holding one of the derivation slots (`slots`: their own, never the upload
  builders'; none free in time, 503 overloaded), then kept in memory and, for a stored model,
  written there atomically. Catalog robots are kept in memory only (the installed catalog may
  change between versions).

Refusals are remembered. A model out of scope is refused in this process before any child
starts (the check is cheap), remembered per robot id. A refusal for the model's cost (past its
time limit with its share of the CPU, its CPU or memory limit: `TooCostly`, a 422
`unsupported_model`) is remembered per content and form: the numbers the derivation reads
(`content_key`: joint kinds, axes, placements, inertias, armature, gravity), so every robot
with the same numbers — the same id again, a variant that only adds friction or a name, any
digits or tolerance — is refused at once with the same 422, without a derivation. A
derivation the machine starved of CPU, or whose child was killed from outside (`Overloaded`,
503), says nothing of the model and is not remembered.

Concurrent requests for the same robot wait for one derivation (single flight), awaited on the
event loop: no thread waits for another request's derivation. The disk and the derivation run
in a thread of their own per derivation (at most the slots plus their waiting room: beyond,
503 at once). A deleted upload's file stays behind harmlessly: an upload with the same id is
the same model.
"""

from __future__ import annotations

import asyncio
import hashlib
import logging
import threading
from collections import OrderedDict
from concurrent.futures import Future
from pathlib import Path
from typing import Any

from service.api.workers.equations import (
    MEMORY_MB,
    PRELOAD,
    Printing,
    TooCostly,
    derive_isolated,
)
from service.dynamics.equations.model_numbers import Joint, gravity, moving_joints
from service.errors import UnsupportedModel
from service.processes.contexts import forkserver_context
from service.registry.build_slots import BuildSlots
from service.registry.robot import Robot
from service.registry.store import write_atomically

log = logging.getLogger("robodyn.equations")

FORMAT_VERSION = "v3"  # the directory of the files on disk; a new answer format gets a new one
MAX_REMEMBERED_REFUSALS = 10_000  # refusals for cost kept (least recently used dropped)
Key = tuple[str, Printing]  # (robot id, printing): one answer


def _identified(robot: Robot) -> dict[str, Any]:
    """`derive_isolated`'s keyword for a robot made by identification: its uncertainty (the
    parametric form's standard deviations); none otherwise."""
    if robot.identified_uncertainty is None:
        return {}
    return {"uncertainty": robot.identified_uncertainty}


def _kept_on_disk(printing: Printing) -> bool:
    """The readable (default) and the exact printing of each form are written to disk."""
    return (printing.digits, printing.tolerance) in ((6, 1e-9), (17, 0.0))


def content_key(model: Any, joints: list[Joint]) -> str:
    """A digest of what the derivation of `model` reads (its `moving_joints` without their
    names, and gravity, as exact decimals): equal for models whose derivations are the same
    work."""
    numbers = [
        (
            j.kind,
            j.axis,
            j.parent,
            j.rotation,
            j.translation,
            j.mass,
            j.lever,
            j.inertia,
            j.armature,
        )
        for j in joints
    ]
    return hashlib.sha256(repr((numbers, gravity(model))).encode()).hexdigest()


class EquationsCache:
    """See the module docstring. `time_limit_s` bounds one derivation; `slots` are the
    derivations' own."""

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
        self._memory: OrderedDict[Key, bytes] = OrderedDict()
        self._bytes = 0
        self._refused: dict[str, UnsupportedModel] = {}  # out of scope, by robot id
        # refused for cost, by (content_key, form)
        self._too_costly: OrderedDict[tuple[str, str], UnsupportedModel] = OrderedDict()
        self._pending: dict[Key, Future[bytes]] = {}
        self._lock = threading.Lock()
        # whoever starts the forkserver first (an upload's build, or a derivation), it imports
        # the derivation's modules: a derivation's child starts with them loaded
        forkserver_context(PRELOAD)

    def _path(self, robot: Robot, printing: Printing) -> Path | None:
        if self.dir is None or robot.source == "catalog" or not _kept_on_disk(printing):
            return None
        return self.dir / robot.id / f"{printing.name()}.json"

    def _remember(self, key: Key, body: bytes) -> None:
        with self._lock:
            if key in self._memory:
                return
            self._memory[key] = body
            self._bytes += len(body)
            while self._bytes > self.max_bytes and len(self._memory) > 1:
                _, dropped = self._memory.popitem(last=False)
                self._bytes -= len(dropped)

    def cached(self, robot: Robot, printing: Printing | None = None) -> bytes | None:
        """The answer when it is in memory (no disk, no derivation); refusals by id raise."""
        key = (robot.id, printing or Printing())
        with self._lock:
            refused = self._refused.get(robot.id)
            if refused is not None:
                raise UnsupportedModel(refused.detail)
            body = self._memory.get(key)
            if body is not None:
                self._memory.move_to_end(key)
            return body

    def _content(self, robot: Robot, form: str) -> tuple[str, str]:
        """The robot's `content_key`; `UnsupportedModel` (remembered) when out of scope or
        already refused for its cost."""
        try:
            joints = moving_joints(robot.model)
        except UnsupportedModel as exc:
            with self._lock:
                self._refused[robot.id] = exc
            raise
        key = (content_key(robot.model, joints), form)
        with self._lock:
            refused = self._too_costly.get(key)
            if refused is not None:
                self._too_costly.move_to_end(key)
                raise UnsupportedModel(refused.detail)
        return key

    async def answer(self, robot: Robot, printing: Printing | None = None) -> bytes:
        """The JSON answer for `robot` printed as asked (see the module docstring)."""
        printing = printing or Printing()
        body = self.cached(robot, printing)
        if body is not None:
            return body
        content = self._content(robot, printing.form)
        key = (robot.id, printing)
        with self._lock:
            pending = self._pending.get(key)
            owner = pending is None
            if pending is None:
                pending = self._pending[key] = Future()
        if owner:
            threading.Thread(
                target=self._settle,
                args=(robot, printing, content, pending),
                name="robodyn-equations",
                daemon=True,
            ).start()
        return await asyncio.wrap_future(pending)

    def _settle(
        self, robot: Robot, printing: Printing, content: tuple[str, str], pending: Future[bytes]
    ) -> None:
        """In the derivation's thread: the answer (disk or derivation) into `pending`."""
        key = (robot.id, printing)
        try:
            body = self._load_or_derive(robot, printing, content)
        except BaseException as exc:
            with self._lock:
                del self._pending[key]
            pending.set_exception(exc)
        else:
            with self._lock:
                del self._pending[key]
            pending.set_result(body)

    def _load_or_derive(self, robot: Robot, printing: Printing, content: tuple[str, str]) -> bytes:
        key = (robot.id, printing)
        path = self._path(robot, printing)
        if path is not None and path.is_file():
            try:
                body = path.read_bytes()
            except OSError as exc:
                log.warning("equations of %s not read from disk: %s", robot.id, exc)
            else:
                self._remember(key, body)
                return body
        with self.slots.slot():
            try:
                body = derive_isolated(
                    robot.model, self.time_limit_s, self.memory_mb, printing, **_identified(robot)
                )
            except TooCostly as exc:  # the model's own cost: remembered by content and form
                with self._lock:
                    self._too_costly[content] = exc
                    while len(self._too_costly) > MAX_REMEMBERED_REFUSALS:
                        self._too_costly.popitem(last=False)
                raise
        self._remember(key, body)
        if path is not None:
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                write_atomically(path, body)
            except OSError as exc:  # a read-only or full disk: the memory copy serves
                log.warning("equations of %s not written to disk: %s", robot.id, exc)
        return body
