"""Work in other processes: started, limited, timed, watched and stopped in one place.

The serving process never runs untrusted parsing or long GIL-holding work itself: model builds
(`service.registry.build_process`), large upload bodies (`service.api.upload_body`), the
derivation of the equations (`service.api.workers.equations`) and the identification fits
(`service.api.workers.identification`) run in children of this package; large JSON bodies are
parsed by its helper pool (`service.api.json_bodies`). No FastAPI and no Pinocchio here: the
registry and the API layer both use it.

    limits      ResourceLimits (address space, CPU time, niceness, open files, no core
                files) applied by each child to itself; forbid_file_writes
    cpu         cpu_seconds of a child (/proc), STARVED_CPU_FRACTION and starved: a child that
                timed out with too little CPU was starved by the machine (503), not slow
    watchdog    die_with_parent: a child is killed when the process that started it ends
                (Linux PR_SET_PDEATHSIG; the forkserver ends with the serving process)
    contexts    the forkserver (with preloaded modules) and spawn contexts; the launcher
                thread spawned children start from; stopping the forkserver, the launcher
                and multiprocessing's resource tracker
    children    start_child and run_child: one child, its answer within a timeout, kill and
                reap; ChildNotStarted, ChildTimedOut, ChildDied
    pools       HelperPool: long-lived spawned helpers behind a ProcessPoolExecutor
    tracking    every live child and pool; shutdown(): stop them all (the app's lifespan,
                the test fixtures)
"""

from service.processes.children import (
    ChildDied,
    ChildNotStarted,
    ChildTimedOut,
    run_child,
    start_child,
)
from service.processes.cpu import STARVED_CPU_FRACTION, cpu_seconds, starved
from service.processes.limits import CHILD_NICENESS, ResourceLimits, forbid_file_writes
from service.processes.pools import HelperPool
from service.processes.tracking import end, live_children, shutdown

__all__ = [
    "CHILD_NICENESS",
    "STARVED_CPU_FRACTION",
    "ChildDied",
    "ChildNotStarted",
    "ChildTimedOut",
    "HelperPool",
    "ResourceLimits",
    "cpu_seconds",
    "end",
    "forbid_file_writes",
    "live_children",
    "run_child",
    "shutdown",
    "start_child",
    "starved",
]
