"""Large batches on every core (Pinocchio's OpenMP algorithms): inverse and forward dynamics,
and gravity and nonlinear effects as RNEA with zero accelerations (and velocities).

`rneaInParallel` and `abaInParallel` take states as columns (nq × N, nv × N); the (N, n)
row-major arrays of `States` are exactly that layout transposed, so no copy is made. They hold
the GIL while they run, so a batch is cut into chunks of `CHUNK_WORK` states × nv (a few
milliseconds): between chunks the event loop gets the interpreter back and single-state
requests stay responsive. OpenMP threads wait passively between calls (`OMP_WAIT_POLICY`, set
in `service/__init__.py`), so they do not spin on the cores the event loop needs.
Each state is computed by the same algorithm as the serial path, so the answers are bit for
bit the same as `pin.rnea` / `pin.aba` state by state (the serial gravity, Pinocchio's
`computeGeneralizedGravity`, equals `rnea(q, 0, 0)` bit for bit: checked on every catalog
robot by the tests; the serial nonlinear effects are `rnea(q, v, 0)`). The answers are checked
finite by `service.dynamics.quantity.run`, as the serial ones by their functions.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pinocchio as pin

from service.dynamics.quantity import Results
from service.registry.robot import Robot
from service.states import States

CHUNK_WORK = 10_000  # states × nv per GIL-holding native call: about 1 ms (Talos, 2 cores)


# Every OpenMP batch of the process runs in this one thread: where teams are bound
# (OMP_PROC_BIND, set by `python -m service`), libgomp binds a team's master to the first core,
# and that must be neither the event loop's thread nor a pool thread that serves other work.
_MASTER = ThreadPoolExecutor(max_workers=1, thread_name_prefix="openmp-master")


def _in_chunks(
    robot: Robot, algorithm: Callable[..., None], q: np.ndarray, x: np.ndarray, y: np.ndarray
) -> np.ndarray:
    """Run `algorithm(threads, pool, q, x, y, out)` over the batch in GIL-friendly chunks, in
    the process's OpenMP master thread."""
    return _MASTER.submit(_run_chunks, robot, algorithm, q, x, y).result()


def _run_chunks(
    robot: Robot, algorithm: Callable[..., None], q: np.ndarray, x: np.ndarray, y: np.ndarray
) -> np.ndarray:
    n = q.shape[0]
    out = np.empty((n, robot.nv))
    size = max(256, CHUNK_WORK // robot.nv)
    with robot.model_pool() as (pool, threads):
        for start in range(0, n, size):
            stop = min(n, start + size)
            algorithm(
                threads, pool, q[start:stop].T, x[start:stop].T, y[start:stop].T, out[start:stop].T
            )
            time.sleep(0)  # hand the GIL to the event loop if it is waiting
    return out


def inverse_dynamics(robot: Robot, s: States) -> Results:
    """τ = M(q) a + C(q, v) v + g(q) for N states on every core (parallel RNEA), (N, nv)."""
    return {"tau": _in_chunks(robot, pin.rneaInParallel, s["q"], s["v"], s["a"])}


def forward_dynamics(robot: Robot, s: States) -> Results:
    """a = M(q)⁻¹ (τ − C(q, v) v − g(q)) for N states on every core (parallel ABA), (N, nv)."""
    return {"a": _in_chunks(robot, pin.abaInParallel, s["q"], s["v"], s["tau"])}


def gravity(robot: Robot, s: States) -> Results:
    """g(q) = RNEA(q, 0, 0) for N states on every core, (N, nv)."""
    q = s["q"]
    zeros = np.zeros((q.shape[0], robot.nv))
    return {"gravity": _in_chunks(robot, pin.rneaInParallel, q, zeros, zeros)}


def nonlinear_effects(robot: Robot, s: States) -> Results:
    """h(q, v) = RNEA(q, v, 0) for N states on every core, (N, nv)."""
    q, v = s["q"], s["v"]
    zeros = np.zeros((q.shape[0], robot.nv))
    return {"nonlinear_effects": _in_chunks(robot, pin.rneaInParallel, q, v, zeros)}
