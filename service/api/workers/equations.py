"""Deriving the equations in a separate process, with a time limit.

The derivation (`service.dynamics.equations`) is pure Python and holds the GIL for its whole
duration (seconds for a 6-joint arm with skewed axes): in a thread of the serving process it
would stall the event loop and `/health/live`. `derive_isolated` runs it in a short-lived child
forked from the forkserver the upload builders use (`service.processes`, with Pinocchio and the
derivation's modules already imported there). The child receives the model in Pinocchio's
binary serialization, is limited (CPU time, address space, no core files; its priority is the
server's, `NICENESS`), derives, renders the answer and sends it back as JSON bytes (encoded
there, so the serving process only forwards them). The parent waits at most the time limit
plus `GRACE_S` seconds of wall clock and then kills the child; the child's CPU limit is the
time limit (rounded up). The time is judged by the parent alone, so that a child the machine
starved is told from one that is too costly.

Outcomes: the JSON bytes; `UnsupportedModel` for a model out of scope or a crash, and its
subclass `TooCostly` for the model's own cost: a derivation past its time limit having had at
least half of it on a CPU, past its CPU limit, or out of memory; `Overloaded` (the machine's
condition, not the model: never to be remembered as the model's) when the child timed out
having had less than half of its time limit on a CPU, when it was killed by SIGKILL from
outside (the kernel's OOM killer), or when no process could be started.
"""

from __future__ import annotations

import logging
import math
import signal
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import orjson

from service.errors import Overloaded, UnsupportedModel
from service.processes import (
    ChildDied,
    ChildNotStarted,
    ChildTimedOut,
    ResourceLimits,
    killed_detail,
    run_child,
)
from service.registry.build_process import FORKSERVER_PRELOAD, model_from_binary, model_to_binary

log = logging.getLogger("robodyn.equations")


class TooCostly(UnsupportedModel):
    """The model's derivation is past its limits (time with its share of the CPU, CPU time,
    memory): a property of the model's numbers, the same on every try (422
    `unsupported_model`, remembered by `equations_cache`)."""


# the forkserver imports these when it starts: the builders' modules and the derivation's
# (its package imports every topic module, scipy with them: seconds a child would pay each time)
PRELOAD = (*FORKSERVER_PRELOAD, "service.dynamics.equations")
MEMORY_MB = 2048  # address space of the child (a skewed 6-joint arm's derivation: ~300 MB)
GRACE_S = 2.0  # the parent waits this much longer than the child's own time limit
# The derivation runs at the serving process's priority, not lowered like the other children:
# a request waits for it (seconds of CPU for a six-joint arm), and at nice 10 on a machine busy
# with other work it would get a few percent of a core. Its slots bound how many run at once.
NICENESS = 0


@dataclass(frozen=True)
class Printing:
    """What the answer is asked for: `form` "numeric" or "parametric", coefficients to
    `digits` significant digits, terms below `tolerance` × their quantity's largest left out
    (`service.dynamics.equations.answer`)."""

    form: str = "numeric"
    digits: int = 6
    tolerance: float = 1e-9

    def name(self) -> str:
        """A file name part that tells one printing from another: `numeric-6-1e-09`."""
        return f"{self.form}-{self.digits}-{self.tolerance!r}"


def _child_derive(
    conn: Any,
    raw_model: bytes,
    memory_mb: int,
    printing: Printing,
    uncertainty: Mapping[str, Any] | None = None,
) -> None:
    """The child (its limits already set): answers ("ok", JSON bytes), ("unsupported",
    detail) or ("too costly", detail). Its time is the parent's to judge (see the module
    docstring)."""
    from service.dynamics.equations import derive_equations, equations_answer

    try:
        model = model_from_binary(raw_model)
        eq = derive_equations(model, form=printing.form, uncertainty=uncertainty)
        answer = equations_answer(eq, printing.digits, printing.tolerance)
        conn.send(("ok", orjson.dumps(answer)))
    except UnsupportedModel as exc:
        conn.send(("unsupported", exc.detail))
    except MemoryError:
        conn.send(
            (
                "too costly",
                f"the derivation of the equations needed more than its "
                f"memory limit of {memory_mb} MB",
            )
        )
    finally:
        conn.close()


def _past_limit(time_limit_s: float) -> TooCostly:
    return TooCostly(
        f"the derivation of the equations did not finish within its time "
        f"limit of {time_limit_s:g} s; the model is too large for the "
        "explicit form"
    )


def _death(died: ChildDied, time_limit_s: float, cpu_limit_s: int) -> Exception:
    """The error of a child that ended without an answer: `Overloaded` when killed from
    outside, `UnsupportedModel` otherwise (its CPU limit: past its time limit)."""
    exitcode = died.exitcode
    if died.killed_from_outside(cpu_limit_s):
        return Overloaded(killed_detail("the process deriving the equations", exitcode))
    if exitcode is not None and -exitcode in (signal.SIGXCPU, signal.SIGKILL):
        return _past_limit(time_limit_s)
    log.error("equations child ended without an answer (exit code %s)", exitcode)
    return UnsupportedModel(
        "the derivation of the equations failed on this model "
        f"(the deriving process ended with code {exitcode})"
    )


def derive_isolated(
    model: Any,
    time_limit_s: float,
    memory_mb: int = MEMORY_MB,
    printing: Printing | None = None,
    uncertainty: Mapping[str, Any] | None = None,
) -> bytes:
    """The JSON answer of `equations_answer` for `model` as `printing` asks, derived in a
    child process within `time_limit_s` seconds of wall clock (see the module docstring);
    `uncertainty`: identification's, of a robot it made (the parametric form's standard
    deviations). Blocking: call it off the event loop."""
    cpu_limit_s = math.ceil(time_limit_s)
    printing = printing or Printing()
    try:
        answer = run_child(
            _child_derive,
            (model_to_binary(model), memory_mb, printing, uncertainty),
            timeout_s=time_limit_s + GRACE_S,
            limits=ResourceLimits(memory_mb=memory_mb, cpu_s=cpu_limit_s, niceness=NICENESS),
            preload=PRELOAD,
        )
    except ChildNotStarted:
        raise Overloaded("could not start a process for the derivation; retry shortly") from None
    except ChildTimedOut as exc:
        if exc.starved(time_limit_s):
            raise Overloaded(
                f"the derivation got only {exc.cpu_s:.1f} s of CPU time in its "
                f"{time_limit_s:g} s: the server is too busy right now; "
                "retry shortly"
            ) from None
        raise _past_limit(time_limit_s) from None
    except ChildDied as exc:
        raise _death(exc, time_limit_s, cpu_limit_s) from None
    if answer[0] == "too costly":
        raise TooCostly(answer[1])
    if answer[0] == "unsupported":
        raise UnsupportedModel(answer[1])
    return bytes(answer[1])
