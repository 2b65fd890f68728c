"""robodyn: rigid-body dynamics of any robot over HTTP, on Pinocchio."""

import os

# Pinocchio's OpenMP batch algorithms (rneaInParallel, abaInParallel) run in short chunks so
# that the event loop keeps answering; by default libgomp's idle threads spin between calls and
# take the cores the event loop needs (measured: chunked batches 2–3× slower, single requests
# delayed). Passive waiting must be chosen before libgomp loads, i.e. before pinocchio is
# imported, hence here. An explicit OMP_WAIT_POLICY in the environment wins.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
# The CPUs this process may use, noted before libgomp can bind the thread that loads it (the
# server binds its OpenMP teams: see `python -m service`, service/__main__.py).
CPUS: frozenset[int] = frozenset(
    os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else range(os.cpu_count() or 1)
)


def unpin_this_thread() -> None:
    """Give the calling thread back every CPU the process had before libgomp bound it (threads
    it starts afterwards inherit that)."""
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, CPUS)


__version__ = "0.1.0"
