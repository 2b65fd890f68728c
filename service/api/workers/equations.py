"""Deriving the equations in a separate process, with a time limit.

The derivation (`service.dynamics.equations`) is pure Python and holds the GIL for its whole
duration (up to tens of seconds for a 6-joint arm with skewed axes): in a thread of the serving
process it would stall the event loop and `/health/live`. `derive_isolated` runs it in a
short-lived child forked from the forkserver the upload builders use
(`service.registry.build_process`), with Pinocchio already
imported there. The child receives the model in Pinocchio's binary serialization, limits
itself (CPU time, address space, nice 10, no core files), derives within its time limit (checked
between the steps of the derivation), renders the answer and sends it back as JSON bytes
(encoded there, so the serving process only forwards them). The parent waits at most the time
limit plus `GRACE_S` seconds of wall clock and then kills the child.

Outcomes: the JSON bytes; `UnsupportedModel` for a model out of scope, a derivation past its
time limit (wall clock or CPU), a child that ran out of memory or crashed; `Overloaded` when the
child timed out having had less than half of its time limit on a CPU (the machine's load, not the
model), or when no process could be started.
"""

from __future__ import annotations

import logging
import os
import resource
import signal
import time
from typing import Any

import orjson

from service.errors import Overloaded, UnsupportedModel
from service.registry.build_process import (
    BUILDER_NICENESS,
    STARVED_CPU_FRACTION,
    cpu_seconds,
    forkserver_context,
    model_from_binary,
    model_to_binary,
)

log = logging.getLogger("robodyn.equations")

MEMORY_MB = 2048  # address space of the child (a skewed 6-joint arm's derivation: ~300 MB)
GRACE_S = 2.0  # the parent waits this much longer than the child's own time limit


def _limit_resources(cpu_s: int, memory_mb: int) -> None:
    memory = memory_mb * 1024 * 1024
    os.nice(BUILDER_NICENESS)
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    resource.setrlimit(resource.RLIMIT_CPU, (cpu_s, cpu_s + 1))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def _child_derive(conn: Any, raw_model: bytes, time_limit_s: float, memory_mb: int) -> None:
    """The child: answers ("ok", JSON bytes) or ("unsupported", detail)."""
    from service.dynamics.equations import derive_equations, equations_answer

    try:
        _limit_resources(int(time_limit_s) + 1, memory_mb)
        model = model_from_binary(raw_model)
        answer = equations_answer(derive_equations(model, time_limit_s=time_limit_s))
        conn.send(("ok", orjson.dumps(answer)))
    except UnsupportedModel as exc:
        conn.send(("unsupported", exc.detail))
    except MemoryError:
        conn.send(
            (
                "unsupported",
                f"the derivation of the equations needed more than its "
                f"memory limit of {memory_mb} MB",
            )
        )
    finally:
        conn.close()


def _past_limit(time_limit_s: float) -> UnsupportedModel:
    return UnsupportedModel(
        f"the derivation of the equations did not finish within its time "
        f"limit of {time_limit_s:g} s; the model is too large for the "
        "explicit form"
    )


def _death(exitcode: int | None, time_limit_s: float) -> UnsupportedModel:
    if exitcode is not None and -exitcode in (signal.SIGXCPU, signal.SIGKILL):
        return _past_limit(time_limit_s)
    log.error("equations child ended without an answer (exit code %s)", exitcode)
    return UnsupportedModel(
        "the derivation of the equations failed on this model "
        f"(the deriving process ended with code {exitcode})"
    )


def derive_isolated(model: Any, time_limit_s: float, memory_mb: int = MEMORY_MB) -> bytes:
    """The JSON answer of `equations_answer` for `model`, derived in a child process within
    `time_limit_s` seconds of wall clock (see the module docstring). Blocking: call it off
    the event loop."""
    ctx = forkserver_context()
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(
        target=_child_derive,
        daemon=True,
        args=(child, model_to_binary(model), time_limit_s, memory_mb),
    )
    started = time.monotonic()
    try:
        proc.start()
    except OSError:
        parent.close()
        raise Overloaded("could not start a process for the derivation; retry shortly") from None
    finally:
        child.close()
    try:
        if not parent.poll(max(0.0, time_limit_s + GRACE_S - (time.monotonic() - started))):
            cpu = cpu_seconds(proc.pid)
            if cpu is not None and cpu < STARVED_CPU_FRACTION * time_limit_s:
                raise Overloaded(
                    f"the derivation got only {cpu:.1f} s of CPU time in its "
                    f"{time_limit_s:g} s: the server is too busy right now; "
                    "retry shortly"
                )
            raise _past_limit(time_limit_s)
        answer = parent.recv()
    except (EOFError, OSError):
        proc.join(5)
        raise _death(proc.exitcode, time_limit_s) from None
    finally:
        parent.close()
        if proc.is_alive():
            proc.kill()
        proc.join(5)
    if answer[0] == "unsupported":
        raise UnsupportedModel(answer[1])
    return bytes(answer[1])
