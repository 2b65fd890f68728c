"""Large batches of state-by-state quantities (mass matrices, Coriolis matrices) on every core:
the batch's states shared between the serving process and long-lived helper processes.

Pinocchio has no parallel CRBA or Coriolis algorithm and its Python bindings hold the GIL, so
threads do not help; `BatchSplit` (the `split` given to `service.dynamics.run` when
`ROBODYN_BATCH_HELPERS` is set: off by default, -1 for one per CPU but the serving process's
own) gives each of its helpers a slice of the states, computes its own slice meanwhile, then
takes the helpers' slices from their shared files. Nothing large crosses a pipe:

- each helper (`processes.ResidentHelper`, spawned, dies with the server) holds an anonymous
  shared file (`processes.SharedFile`, at most `ROBODYN_BATCH_HELPER_BUFFER_MB`, kept mapped
  from request to request so its pages are warm) into which the serving process writes the
  slice's inputs and the helper its slice of the answer; only a short message with offsets
  and shapes goes through the pipe;
- each helper keeps the models it has been sent, by the SHA-256 of the model's Pinocchio
  binary serialization (`registry.build_process.model_to_binary`, what the builder sends):
  a model is sent to a helper once (at most `MODELS_PER_HELPER` kept, the least recently
  used forgotten);
- every process runs the quantity's own `state_by_state.fill` on its states, the same
  algorithm per state, so the answer is bit for bit the serial one.

A batch is split only above `MIN_SPLIT_WORK` states × nv (below, the messages cost more than
the second core saves), only with helpers that are ready and idle (a helper still importing
its modules after its start, or busy with another request's batch, is not waited for), and
a helper's slice only as large as its shared file holds. A helper that fails, ends (killed)
or does not answer within its wait (`helper_wait_s`: the serving process's own time for its
slice, times `WAIT_FACTOR`, plus `WAIT_MIN_S`) is stopped (a new one is started by the next
batch) and its slice computed in the serving process: the answer is always the serial one.
"""

from __future__ import annotations

import hashlib
import logging
import threading
import time
import weakref
from collections import OrderedDict
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from service.processes import ResidentHelper, ResourceLimits, SharedFile
from service.states import States

log = logging.getLogger("robodyn.batches")

MIN_SPLIT_WORK = 20_000
"""States × nv of the smallest batch that is split (about 500 Talos states): below, the
messages and copies cost about what the helpers save (measured: docs/performance.md)."""
HELPER_SHARE = 1.0
"""A helper's slice is this many times the serving process's: the serving process also
writes the helpers' inputs and copies their answers out."""
MODELS_PER_HELPER = 16
WAIT_FACTOR = 4.0
WAIT_MIN_S = 2.0
FLOAT = np.dtype(np.float64)


def model_digest(robot: Any) -> str:
    """The SHA-256 of the robot's model in Pinocchio's binary serialization (cached per
    robot: the key under which helpers keep the model)."""
    key = id(robot)
    known = _digests.get(key)
    if known is None:
        from service.registry.build_process import model_to_binary

        known = hashlib.sha256(model_to_binary(robot.model)).hexdigest()
        _digests[key] = known
        weakref.finalize(robot, _digests.pop, key, None)
    return known


_digests: dict[int, str] = {}


@dataclass
class _Slot:
    """One helper, its shared file and the models it holds (digests, least recent first)."""

    helper: ResidentHelper
    buffer: SharedFile
    models: OrderedDict[str, None] = field(default_factory=OrderedDict)
    generation: int = 0  # the helper's generation `models` and the handle were given to


@dataclass
class _Part:
    """A helper's slice of a batch: states [start, stop), where its arrays lie in its file."""

    slot: _Slot
    start: int
    stop: int
    outputs: dict[str, tuple[int, tuple[int, ...]]]


class BatchSplit:
    """The `split` of `service.dynamics.run` (module docstring): `helpers` helper processes,
    each with a shared file of at most `buffer_bytes`. Thread-safe."""

    def __init__(self, helpers: int, buffer_bytes: int) -> None:
        self.processes = helpers + 1
        self._buffer_bytes = buffer_bytes
        self._slots: list[_Slot] = []
        self._lock = threading.Lock()
        self._count = helpers
        self._closed = False

    def __call__(self, robot: Any, quantity: Any, s: States, out: dict[str, np.ndarray]) -> None:
        by_state = quantity.state_by_state
        n = s.count
        if n * robot.nv < MIN_SPLIT_WORK or self._count == 0:
            by_state.fill(robot, s, out)
            return
        slots = self._idle_slots()
        pending: list[_Part] = []
        try:
            pending = self._hand_out(robot, quantity.name, s, out, slots)
            own = pending[0].start if pending else n
            started = time.perf_counter()
            by_state.fill(robot, _rows(s, 0, own), _out_rows(out, 0, own))
            wait_s = WAIT_MIN_S + WAIT_FACTOR * (time.perf_counter() - started)
            while pending:
                part = pending.pop(0)
                if not self._collect(part, out, wait_s):
                    rows = (part.start, part.stop)
                    by_state.fill(robot, _rows(s, *rows), _out_rows(out, *rows))
        finally:
            for part in pending:  # not collected (this process's slice raised): their replies
                part.slot.helper.stop()  # would be read by the next batch
            for slot in slots:
                slot.helper.lock.release()

    def _idle_slots(self) -> list[_Slot]:
        """The helpers ready and idle now, locked for this batch (helpers not running are
        started: they serve a later batch)."""
        with self._lock:
            if self._closed:
                return []
            while len(self._slots) < self._count:
                self._slots.append(
                    _Slot(
                        ResidentHelper(helper_main, ResourceLimits(niceness=0), "robodyn-batch"),
                        SharedFile(self._buffer_bytes, "robodyn-batch"),
                    )
                )
            slots = list(self._slots)
        idle = []
        for slot in slots:
            if not slot.helper.lock.acquire(blocking=False):
                continue
            try:
                if not slot.helper.running:
                    slot.helper.start()
                if slot.generation != slot.helper.generation:
                    slot.models.clear()
                    slot.helper.send_handle(slot.buffer.fd)
                    slot.generation = slot.helper.generation
                if slot.helper.ready():
                    idle.append(slot)
                    continue
            except Exception:  # not started (no processes left): computed here
                log.warning("a batch helper could not be started", exc_info=True)
                slot.helper.stop()
            slot.helper.lock.release()
        return idle

    def _hand_out(
        self, robot: Any, name: str, s: States, out: dict[str, np.ndarray], slots: list[_Slot]
    ) -> list[_Part]:
        """Send each helper its slice (the last slices of the batch; the first is this
        process's); returns the slices sent. A helper that fails here gets none."""
        n = s.count
        if not slots:
            return []
        share = n / (len(slots) * HELPER_SHARE + 1) * HELPER_SHARE
        per_state = sum(a[0].nbytes for a in s.arrays.values()) + sum(
            a[0].nbytes for a in out.values()
        )
        parts: list[_Part] = []
        stop = n
        for slot in slots:
            count = min(int(share), slot.buffer.max_bytes // max(per_state, 1))
            start = stop - count
            if count <= 0 or not slot.buffer.reserve(count * per_state):
                continue
            try:
                parts.append(self._send(robot, name, s, out, slot, start, stop))
            except Exception:
                log.warning("a batch helper failed; its slice is computed here", exc_info=True)
                slot.helper.stop()
                continue
            stop = start
        parts.reverse()
        return parts

    def _send(
        self,
        robot: Any,
        name: str,
        s: States,
        out: dict[str, np.ndarray],
        slot: _Slot,
        start: int,
        stop: int,
    ) -> _Part:
        digest = model_digest(robot)
        if digest in slot.models:
            slot.models.move_to_end(digest)
        else:
            from service.registry.build_process import model_to_binary

            slot.helper.send(("model", digest, model_to_binary(robot.model)))
            slot.models[digest] = None
            while len(slot.models) > MODELS_PER_HELPER:
                slot.helper.send(("forget", slot.models.popitem(last=False)[0]))
        assert slot.buffer.map is not None
        offset = 0
        inputs: dict[str, tuple[int, tuple[int, ...]]] = {}
        for key, array in s.arrays.items():
            rows = array[start:stop]
            view = np.ndarray(rows.shape, FLOAT, buffer=slot.buffer.map, offset=offset)
            view[...] = rows
            inputs[key] = (offset, rows.shape)
            offset += rows.nbytes
        outputs: dict[str, tuple[int, tuple[int, ...]]] = {}
        for key, array in out.items():
            shape = (stop - start, *array.shape[1:])
            outputs[key] = (offset, shape)
            offset += int(np.prod(shape)) * FLOAT.itemsize
        del view
        slot.helper.send(("fill", digest, name, slot.buffer.size, inputs, outputs))
        return _Part(slot, start, stop, outputs)

    def _collect(self, part: _Part, out: dict[str, np.ndarray], wait_s: float) -> bool:
        """Copy a helper's slice into `out`; False when the helper failed (it is stopped
        unless it reported an error of its own)."""
        slot = part.slot
        try:
            reply = slot.helper.wait_reply(wait_s)
        except Exception as exc:  # ended or did not answer in time: stopped
            log.warning("a batch helper gave no answer (%s); its slice is computed here", exc)
            return False
        if reply[0] != "done":
            log.warning("a batch helper failed (%s); its slice is computed here", reply[1])
            return False
        assert slot.buffer.map is not None
        for key, (offset, shape) in part.outputs.items():
            view = np.ndarray(shape, FLOAT, buffer=slot.buffer.map, offset=offset)
            out[key][part.start : part.stop] = view
            del view
        return True

    def close(self) -> None:
        """Stop the helpers and free their files (a later batch is computed in-process)."""
        with self._lock:
            self._closed = True
            slots, self._slots = self._slots, []
        for slot in slots:
            slot.helper.stop()
            slot.buffer.close()


def _rows(s: States, start: int, stop: int) -> States:
    return States({k: a[start:stop] for k, a in s.arrays.items()}, True, first=s.first + start)


def _out_rows(out: dict[str, np.ndarray], start: int, stop: int) -> dict[str, np.ndarray]:
    return {k: a[start:stop] for k, a in out.items()}


def helper_main(conn: Connection) -> None:
    """A helper process: receive its shared file, say it is ready, then serve messages until
    its pipe closes: ("model", digest, binary) keeps a model, ("forget", digest) drops one,
    ("fill", digest, quantity, file size, inputs, outputs) computes a slice ((offset, shape)
    of each array in the file) and answers ("done",) or ("failed", reason)."""
    import mmap
    from multiprocessing.reduction import recv_handle

    from service import unpin_this_thread
    from service.dynamics import QUANTITIES
    from service.registry.build_process import model_from_binary
    from service.registry.robot import Robot

    # libgomp bound this thread to one CPU as Pinocchio loaded (the server's OMP_PROC_BIND,
    # inherited): the helper runs wherever the machine has room, as the serving process does
    unpin_this_thread()
    fd = recv_handle(conn)
    conn.send("ready")
    robots: dict[str, Robot] = {}
    mapping: mmap.mmap | None = None
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        kind = message[0]
        if kind == "model":
            robots[message[1]] = Robot(
                message[1], message[1], "helper", "", model_from_binary(message[2])
            )
        elif kind == "forget":
            robots.pop(message[1], None)
        elif kind == "fill":
            _, digest, name, size, inputs, outputs = message
            try:
                if mapping is None or len(mapping) != size:
                    if mapping is not None:
                        mapping.close()
                    mapping = mmap.mmap(fd, size)
                arrays = {
                    k: np.ndarray(shape, FLOAT, buffer=mapping, offset=offset)
                    for k, (offset, shape) in inputs.items()
                }
                answers = {
                    k: np.ndarray(shape, FLOAT, buffer=mapping, offset=offset)
                    for k, (offset, shape) in outputs.items()
                }
                QUANTITIES[name].state_by_state.fill(robots[digest], States(arrays, True), answers)  # type: ignore[union-attr]
                del arrays, answers
                conn.send(("done",))
            except Exception as exc:
                arrays = answers = {}
                conn.send(("failed", f"{type(exc).__name__}: {exc}"))
