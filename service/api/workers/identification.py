"""Identification off the serving process: one worker process, one fit at a time, a time limit.

A fit holds the GIL for seconds (the regressor over every sample, the filter, the semidefinite
program), so the service never runs it in its own process. `IdentificationWorker.identify`
sends the robot (Pinocchio's binary model and what rebuilds its `Robot`) and the log to a
long-lived worker process (spawned once by `service.processes.start_child`, with the
identification modules (`service.dynamics.identification`) imported; at a lower CPU priority,
nice 10, and an address-space limit) and waits for the answer:

- at most one fit runs per worker and at most `max_waiting` more wait for it; beyond that the
  call raises `Overloaded` (503) at once;
- a fit that takes longer than `timeout_s` seconds of wall clock is stopped (the worker is
  killed and a new one started for the next fit): `Overloaded` when the worker got less than
  half of that time on a CPU (the machine was busy), else `InvalidInput` saying the log is too
  large for the limit;
- the domain errors of `identify` (bad input) come back as themselves; a worker that dies
  (e.g. over its memory limit) is `InvalidInput` saying so.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from service import errors
from service.dynamics.identification.pipeline import Identification, Progress
from service.processes import ChildNotStarted, ResourceLimits, cpu_seconds, end, start_child
from service.processes import starved as starved_of_cpu
from service.registry.build_process import model_from_binary, model_to_binary
from service.registry.robot import Robot


def _serve(conn: Any, memory_mb: int) -> None:
    """The worker process (its limits already set): fit every job it receives until its pipe
    closes."""
    from service.dynamics.identification.pipeline import identify

    conn.send(("ready",))
    while True:
        try:
            raw, meta, arrays, options = conn.recv()
        except (EOFError, OSError):
            return
        try:
            robot = Robot(model=model_from_binary(raw), **meta)

            def progress(*event: Any) -> None:
                conn.send(("progress", *event))

            conn.send(("ok", identify(robot, **arrays, **options, progress=progress)))
        except errors.RobodynError as exc:
            conn.send(("error", type(exc).__name__, exc.detail))
        except MemoryError:
            conn.send(
                (
                    "error",
                    "InvalidInput",
                    f"the identification needed more than its "
                    f"memory limit of {memory_mb} MB: send a shorter log",
                )
            )
        except Exception as exc:  # a bug: reported as such, without a traceback
            conn.send(("failed", type(exc).__name__))


class IdentificationWorker:
    """A worker process for `identify` (see the module docstring). Thread-safe."""

    def __init__(
        self, timeout_s: float = 120.0, memory_mb: int = 4096, max_waiting: int = 1
    ) -> None:
        self.timeout_s = timeout_s
        self.memory_mb = memory_mb
        self.max_waiting = max_waiting
        self._lock = threading.Lock()  # one fit at a time
        self._count_lock = threading.Lock()
        self._queued = 0  # running + waiting
        self._proc: Any = None
        self._conn: Any = None

    def _start(self) -> None:
        try:
            proc, parent = start_child(
                _serve,
                (self.memory_mb,),
                limits=ResourceLimits(memory_mb=self.memory_mb),
                start="spawn",
                duplex=True,
                name="robodyn-identification",
            )
        except ChildNotStarted:
            raise errors.Overloaded(
                "could not start an identification worker; retry shortly"
            ) from None
        self._proc, self._conn = proc, parent
        if not parent.poll(60.0) or parent.recv() != ("ready",):
            self._stop()
            raise errors.Overloaded(
                "the identification worker did not start in time; retry shortly"
            )

    def _stop(self) -> None:
        if self._conn is not None:
            self._conn.close()
        if self._proc is not None:
            end(self._proc)
        self._proc = self._conn = None

    def close(self) -> None:
        with self._lock:
            self._stop()

    def identify(
        self, robot: Robot, progress: Progress | None = None, **inputs: Any
    ) -> Identification:
        """`identify(robot, **inputs)` in the worker (t, q, tau, v, a as arrays; the other
        options as `identify` takes them); `progress` (optional) hears its stages, from this
        thread."""
        with self._count_lock:
            if self._queued > self.max_waiting:
                raise errors.Overloaded(
                    "identifications are already running and waiting; retry when they are done"
                )
            self._queued += 1
        try:
            with self._lock:
                return self._run(robot, inputs, progress)
        finally:
            with self._count_lock:
                self._queued -= 1

    def _run(
        self, robot: Robot, inputs: dict[str, Any], progress: Progress | None
    ) -> Identification:
        if self._proc is None or not self._proc.is_alive():
            self._stop()
            self._start()
        arrays = {k: inputs.pop(k) for k in ("t", "q", "tau", "v", "a") if k in inputs}
        meta = {
            "id": robot.id,
            "name": robot.name,
            "source": robot.source,
            "root_joint": robot.root_joint,
            "mujoco_qpos": robot.mujoco_qpos,
        }
        started_cpu = cpu_seconds(self._proc.pid)
        start = time.monotonic()
        try:
            self._conn.send((model_to_binary(robot.model), meta, arrays, inputs))
            while True:
                remaining = start + self.timeout_s - time.monotonic()
                if remaining <= 0 or not self._conn.poll(remaining):
                    raise self._timed_out(started_cpu, time.monotonic() - start)
                answer = self._conn.recv()
                if answer[0] != "progress":
                    break
                if progress is not None:
                    progress(*answer[1:])
        except (EOFError, OSError, BrokenPipeError):
            self._stop()
            raise errors.InvalidInput(
                f"the identification worker stopped on this log (over its memory limit of "
                f"{self.memory_mb} MB?): send a shorter log"
            ) from None
        if answer[0] == "ok":
            result: Identification = answer[1]
            return result
        if answer[0] == "error":
            raise getattr(errors, answer[1], errors.InvalidInput)(answer[2])
        raise RuntimeError(f"identification failed in its worker ({answer[1]})")

    def _timed_out(self, started_cpu: float | None, elapsed: float) -> errors.RobodynError:
        cpu = cpu_seconds(self._proc.pid) if self._proc is not None else None
        self._stop()
        if (
            cpu is not None
            and started_cpu is not None
            and starved_of_cpu(cpu - started_cpu, elapsed)
        ):
            return errors.Overloaded(
                f"the identification got only {cpu - started_cpu:.1f} s of CPU time in its "
                f"{self.timeout_s:g} s limit: the server is too busy right now; retry shortly"
            )
        return errors.InvalidInput(
            f"the identification took longer than its limit of {self.timeout_s:g} s: send a "
            "shorter log or one sampled less often"
        )
