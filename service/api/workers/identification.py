"""Identification off the serving process: one worker process, one fit at a time, a bounded
queue, a time limit, and a fit that stops as soon as nobody waits for it.

A fit holds the GIL for seconds (the regressor over every sample, the filter, the semidefinite
program), so the service never runs it in its own process. `await IdentificationWorker.identify`
queues the robot (Pinocchio's binary model and what rebuilds its `Robot`) and the log for a
long-lived worker process (spawned by `service.processes.start_child`, with the identification
modules (`service.dynamics.identification`) imported; at a lower CPU priority, nice 10, and an
address-space limit) and awaits the answer on the event loop: no request thread waits for the
worker. One driver thread per worker sends each fit and reads its progress and answer.

- One fit runs in the worker at a time and at most `max_waiting` more wait in its queue; beyond
  that the call raises `Overloaded` (503, Retry-After) at once.
- A fit that takes longer than `timeout_s` seconds of wall clock from its start (waiting in the
  queue is not counted) is stopped: the worker process is killed (a fit cannot be interrupted
  otherwise) and a new one started for the next fit. `Overloaded` when the worker got less
  than half of that time on a CPU (the machine was busy), else `InvalidInput` saying the log
  is too large for the limit.
- A call that is cancelled (its client disconnected, `service.api.routes.identification`)
  leaves the queue, or, when its fit is running, stops it the same way at once:
  `ComputationStopped`.
- The domain errors of `identify` (bad input) come back as themselves. A worker that dies on
  its own is `InvalidInput` (e.g. a native allocation over its memory limit), except when it
  was killed by SIGKILL from outside (the kernel's OOM killer): `Overloaded`, the machine's
  condition, not the log's.
"""

from __future__ import annotations

import asyncio
import contextlib
import signal
import threading
import time
from collections import deque
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import Any

from service import errors
from service.dynamics.identification.pipeline import Identification, Progress
from service.processes import (
    ChildNotStarted,
    ResourceLimits,
    cpu_seconds,
    disown,
    end,
    killed_detail,
    own,
    start_child,
)
from service.processes import starved as starved_of_cpu
from service.registry.build_process import model_from_binary, model_to_binary
from service.registry.robot import Robot

START_TIMEOUT_S = 60.0  # a new worker must say it is ready within this (it imports the fit)


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


@dataclass(eq=False)
class _Fit:
    """One queued or running fit."""

    robot: Robot
    inputs: dict[str, Any]
    progress: Progress | None
    future: Future[Identification] = field(default_factory=Future)
    sent: bool = False  # to the worker: stopping it now means killing the worker
    stopped: str | None = None  # why it stopped: "timeout", "cancelled", "closed"
    cpu_s: float | None = None  # the worker's CPU time when it was killed for its timeout


class IdentificationWorker:
    """A worker process for `identify` (see the module docstring). Thread-safe; its calls may
    come from any event loop."""

    def __init__(
        self, timeout_s: float = 120.0, memory_mb: int = 4096, max_waiting: int = 1
    ) -> None:
        self.timeout_s = timeout_s
        self.memory_mb = memory_mb
        self.max_waiting = max_waiting
        self._lock = threading.Lock()  # the fields below; never held while waiting
        self._queue: deque[_Fit] = deque()
        self._wake = threading.Condition(self._lock)
        self._running: _Fit | None = None
        self._proc: Any = None
        self._conn: Any = None
        self._driver: threading.Thread | None = None
        self._generation = 0  # a driver serves while it is the current one (`close`)
        self._pipe_lock = threading.Lock()  # closing a pipe (`_close_pipe`)

    async def identify(
        self, robot: Robot, progress: Progress | None = None, **inputs: Any
    ) -> Identification:
        """`identify(robot, **inputs)` in the worker (t, q, tau, v, a as arrays; the other
        options as `identify` takes them); `progress` (optional) hears its stages, from the
        driver thread. Cancelling the call stops its fit (see the module docstring)."""
        fit = self._submit(_Fit(robot, inputs, progress))
        try:
            return await asyncio.wrap_future(fit.future)
        except asyncio.CancelledError:
            self._cancel(fit)
            raise

    def _submit(self, fit: _Fit) -> _Fit:
        with self._lock:
            if len(self._queue) + (self._running is not None) > self.max_waiting:
                raise errors.Overloaded(
                    "identifications are already running and waiting; retry when they are done"
                )
            self._queue.append(fit)
            if self._driver is None:
                self._driver = threading.Thread(
                    target=self._drive,
                    args=(self._generation,),
                    name="robodyn-identification",
                    daemon=True,
                )
                self._driver.start()
                own(self)  # `processes.shutdown` closes it
            self._wake.notify()
        return fit

    def _cancel(self, fit: _Fit) -> None:
        """Take `fit` out of the queue, or stop it if it runs (its worker is killed)."""
        with self._lock:
            if fit in self._queue:
                self._queue.remove(fit)
                fit.future.cancel()
            elif fit is self._running and fit.stopped is None:
                fit.stopped = "cancelled"
                if fit.sent:
                    self._kill_worker()

    def close(self) -> None:
        """Stop everything at once: queued fits fail, the running one is stopped, the worker
        process is killed and the driver ends (a later call starts them again). Never waits
        for a fit."""
        with self._lock:
            self._generation += 1
            self._driver = None
            queued, self._queue = list(self._queue), deque()
            running = self._running
            busy = running is not None
            if running is not None and running.stopped is None:
                running.stopped = "closed"
            proc, conn = self._proc, self._conn
            self._proc = self._conn = None
            self._wake.notify_all()
        for fit in queued:
            fit.future.set_exception(errors.Overloaded("the server is stopping; retry shortly"))
        if proc is not None:
            end(proc)  # killed and reaped: the driver's send or receive ends
        if conn is not None and not busy:  # else the driver closes it
            self._close_pipe(conn)
        disown(self)

    def _close_pipe(self, conn: Any) -> None:
        """Close a worker's pipe once, whichever thread comes first (`close` and the driver
        may both try)."""
        with self._pipe_lock:
            if not conn.closed:
                with contextlib.suppress(OSError):
                    conn.close()

    def _kill_worker(self) -> None:
        """Kill the worker process (the lock held): the driver's send or receive then ends."""
        if self._proc is not None and self._proc.is_alive():
            self._proc.kill()

    def _drive(self, generation: int) -> None:
        """The driver thread: run the queued fits one by one while `generation` is current."""
        while True:
            with self._lock:
                while not self._queue and generation == self._generation:
                    self._wake.wait()
                if generation != self._generation:
                    return
                fit = self._queue.popleft()
                self._running = fit
            if fit.future.set_running_or_notify_cancel():
                try:
                    fit.future.set_result(self._fit(fit, generation))
                except BaseException as exc:
                    fit.future.set_exception(exc)
            with self._lock:
                self._running = None
                restart = fit.stopped in ("timeout", "cancelled")
                restart = restart and generation == self._generation and self._proc is None
            if restart:  # a killed worker is replaced now, not when the next fit comes
                with contextlib.suppress(errors.Overloaded):  # else the next fit tries again
                    self._worker(generation)

    def _worker(self, generation: int) -> tuple[Any, Any]:
        """The running worker process and its pipe, started if there is none (or it died),
        for the driver of `generation` (a worker started while `close` ran is ended)."""
        with self._lock:
            proc, conn = self._proc, self._conn
        if proc is not None and proc.is_alive():
            return proc, conn
        self._forget(proc, conn)
        try:
            proc, conn = start_child(
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
        with self._lock:
            current = generation == self._generation
            if current:
                self._proc, self._conn = proc, conn
        if not current:
            self._forget(proc, conn)
            raise errors.Overloaded("the server is stopping; retry shortly")
        try:
            ready = conn.poll(START_TIMEOUT_S) and conn.recv() == ("ready",)
        except (EOFError, OSError):
            ready = False
        if not ready:
            self._forget(proc, conn)
            raise errors.Overloaded(
                "the identification worker did not start in time; retry shortly"
            )
        return proc, conn

    def _forget(self, proc: Any, conn: Any) -> None:
        """Close, kill and reap a worker process, and drop it if it is the current one."""
        with self._lock:
            if self._proc is proc:
                self._proc = self._conn = None
        if conn is not None:
            self._close_pipe(conn)
        if proc is not None:
            end(proc)

    def _time_out(self, fit: _Fit, proc: Any) -> None:
        """At the fit's time limit (a timer thread): note the worker's CPU time, kill it."""
        with self._lock:
            if fit is self._running and fit.stopped is None and proc is self._proc:
                fit.stopped = "timeout"
                fit.cpu_s = cpu_seconds(proc.pid)
                self._kill_worker()

    def _fit(self, fit: _Fit, generation: int) -> Identification:
        """In the driver thread: the fit's answer from the worker process."""
        proc, conn = self._worker(generation)
        robot, inputs = fit.robot, dict(fit.inputs)
        arrays = {k: inputs.pop(k) for k in ("t", "q", "tau", "v", "a") if k in inputs}
        meta = {
            "id": robot.id,
            "name": robot.name,
            "source": robot.source,
            "root_joint": robot.root_joint,
            "mujoco_qpos": robot.mujoco_qpos,
        }
        job = (model_to_binary(robot.model), meta, arrays, inputs)
        with self._lock:
            if fit.stopped is not None:  # cancelled while the worker started: it is kept
                raise self._ended(fit, None, None, 0.0)
            fit.sent = True
        started_cpu = cpu_seconds(proc.pid)
        start = time.monotonic()
        limit = threading.Timer(self.timeout_s, self._time_out, (fit, proc))
        limit.daemon = True
        limit.start()
        try:
            conn.send(job)
            while True:
                answer = conn.recv()
                if answer[0] != "progress":
                    break
                if fit.progress is not None:
                    fit.progress(*answer[1:])
        except (EOFError, OSError):  # the worker ended: killed by us, or died
            limit.cancel()
            self._forget(proc, conn)
            raise self._ended(fit, proc.exitcode, started_cpu, time.monotonic() - start) from None
        finally:
            limit.cancel()
        if answer[0] == "ok":
            result: Identification = answer[1]
            return result
        if answer[0] == "error":
            raise getattr(errors, answer[1], errors.InvalidInput)(answer[2])
        raise RuntimeError(f"identification failed in its worker ({answer[1]})")

    def _ended(
        self, fit: _Fit, exitcode: int | None, started_cpu: float | None, elapsed: float
    ) -> errors.RobodynError:
        """The error of a fit whose worker process ended under it."""
        if fit.stopped == "cancelled":
            return errors.ComputationStopped("identify: stopped, the client closed the connection")
        if fit.stopped == "closed":
            return errors.Overloaded("the server is stopping; retry shortly")
        if fit.stopped == "timeout":
            used = None if fit.cpu_s is None or started_cpu is None else fit.cpu_s - started_cpu
            if used is not None and starved_of_cpu(used, elapsed):
                return errors.Overloaded(
                    f"the identification got only {used:.1f} s of CPU time in its "
                    f"{self.timeout_s:g} s limit: the server is too busy right now; retry "
                    "shortly"
                )
            return errors.InvalidInput(
                f"the identification took longer than its limit of {self.timeout_s:g} s: send "
                "a shorter log or one sampled less often"
            )
        if exitcode == -signal.SIGKILL:  # not by us: the OOM killer, an operator
            return errors.Overloaded(killed_detail("the identification worker", exitcode))
        return errors.InvalidInput(
            f"the identification worker stopped on this log (over its memory limit of "
            f"{self.memory_mb} MB?): send a shorter log"
        )
