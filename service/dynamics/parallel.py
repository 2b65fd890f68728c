"""Large batches on every core (Pinocchio's OpenMP algorithms): inverse and forward dynamics,
and gravity and nonlinear effects as RNEA with zero accelerations (and velocities).

`rneaInParallel` and `abaInParallel` take states as columns (nq × N, nv × N); the (N, n)
row-major arrays of `States` are exactly that layout transposed, so no copy is made. They hold
the GIL while they run, so a batch is cut into chunks of `CHUNK_WORK` states × nv (about a
millisecond): between chunks the event loop gets the interpreter back and single-state
requests stay responsive, and the request's `should_stop` is asked (its deadline, its client's
disconnect). When the caller's `should_stop` says the process has nothing else to serve and the
deadline is far (`stopping.may_hold`), the rest of the batch is one call: one fork and join of
the OpenMP team instead of one a millisecond. OpenMP threads wait passively between calls
(`OMP_WAIT_POLICY`, set in `service/__init__.py`), so they do not spin on the cores the event
loop needs.
Each state is computed by the same algorithm as the serial path, so the answers are bit for
bit the same as `pin.rnea` / `pin.aba` state by state (the serial gravity, Pinocchio's
`computeGeneralizedGravity`, equals `rnea(q, 0, 0)` bit for bit: checked on every catalog
robot by the tests; the serial nonlinear effects are `rnea(q, v, 0)`). The answers are checked
finite by `service.dynamics.quantity.run`, as the serial ones by their functions.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pinocchio as pin

from service.dynamics import answer_arrays
from service.dynamics.quantity import Results
from service.dynamics.stopping import ShouldStop, may_hold, report_progress
from service.errors import ComputationStopped
from service.registry.robot import Robot
from service.states import States

CHUNK_WORK = 10_000  # states × nv per GIL-holding native call: about 1 ms (Talos, 2 cores)


# Every OpenMP batch of the process runs in this one thread: where teams are bound
# (OMP_PROC_BIND, set by `python -m service`), libgomp binds a team's master to the first core,
# and that must be neither the event loop's thread nor a pool thread that serves other work.
_MASTER_NAME = "openmp-master"
OPENMP_MASTER = ThreadPoolExecutor(max_workers=1, thread_name_prefix=_MASTER_NAME)
"""The process's OpenMP master thread. A caller may run a whole parallel batch in it (its
validation too: one thread hop fewer each way, 0.2–0.4 ms of a co-located request); the
batch is then computed there directly."""


def _in_chunks(
    robot: Robot,
    algorithm: Callable[..., None],
    q: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    should_stop: ShouldStop | None = None,
) -> np.ndarray:
    """Run `algorithm(threads, pool, q, x, y, out)` over the batch in GIL-friendly chunks, in
    the process's OpenMP master thread, asking `should_stop` before each chunk; the answer
    (N, nv) is made here, in the request's context (`answer_arrays`)."""
    out = answer_arrays.empty({"out": (q.shape[0], robot.nv)})["out"]
    if threading.current_thread().name.startswith(_MASTER_NAME):
        return _run_chunks(robot, algorithm, q, x, y, out, should_stop)
    return OPENMP_MASTER.submit(_run_chunks, robot, algorithm, q, x, y, out, should_stop).result()


def _run_chunks(
    robot: Robot,
    algorithm: Callable[..., None],
    q: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    out: np.ndarray,
    should_stop: ShouldStop | None,
) -> np.ndarray:
    """The answer `out` (N, nv), written chunk by chunk. Chunks are `CHUNK_WORK` states × nv; after
    each, when `should_stop` allows holding the interpreter for the rest at the rate of the
    last chunk (`stopping.may_hold`: nothing else to serve, the deadline far), the rest is
    one call."""
    n = q.shape[0]
    size = max(256, CHUNK_WORK // robot.nv)
    seconds_per_state = 0.0
    with robot.model_pool() as (pool, threads):
        start = 0
        while start < n:
            if should_stop is not None:
                if should_stop():
                    raise ComputationStopped(
                        f"stopped at state {start} of {n} (the client went away or the "
                        "request's deadline passed)"
                    )
                report_progress(should_stop, start, n, "state")
            stop = min(n, start + size)
            if seconds_per_state and may_hold(should_stop, seconds_per_state * (n - start)):
                stop = n
            began = time.perf_counter()
            algorithm(
                threads, pool, q[start:stop].T, x[start:stop].T, y[start:stop].T, out[start:stop].T
            )
            seconds_per_state = (time.perf_counter() - began) / (stop - start)
            start = stop
            time.sleep(0)  # hand the GIL to the event loop if it is waiting
    return out


def inverse_dynamics(robot: Robot, s: States, should_stop: ShouldStop | None = None) -> Results:
    """τ = M(q) a + C(q, v) v + g(q) for N states on every core (parallel RNEA), (N, nv)."""
    return {"tau": _in_chunks(robot, pin.rneaInParallel, s["q"], s["v"], s["a"], should_stop)}


def forward_dynamics(robot: Robot, s: States, should_stop: ShouldStop | None = None) -> Results:
    """a = M(q)⁻¹ (τ − C(q, v) v − g(q)) for N states on every core (parallel ABA), (N, nv)."""
    return {"a": _in_chunks(robot, pin.abaInParallel, s["q"], s["v"], s["tau"], should_stop)}


def gravity(robot: Robot, s: States, should_stop: ShouldStop | None = None) -> Results:
    """g(q) = RNEA(q, 0, 0) for N states on every core, (N, nv)."""
    q = s["q"]
    zeros = np.zeros((q.shape[0], robot.nv))
    return {"gravity": _in_chunks(robot, pin.rneaInParallel, q, zeros, zeros, should_stop)}


def nonlinear_effects(robot: Robot, s: States, should_stop: ShouldStop | None = None) -> Results:
    """h(q, v) = RNEA(q, v, 0) for N states on every core, (N, nv)."""
    q, v = s["q"], s["v"]
    zeros = np.zeros((q.shape[0], robot.nv))
    return {"nonlinear_effects": _in_chunks(robot, pin.rneaInParallel, q, v, zeros, should_stop)}
