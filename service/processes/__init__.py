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
                (Linux PR_SET_PDEATHSIG; the forkserver ends with the serving process);
                die_with_supervisor: a serving process of `--workers N` ends with uvicorn's
                supervisor
    contexts    the forkserver (with preloaded modules) and spawn contexts; the launcher
                thread spawned children start from; stopping the forkserver, the launcher
                and multiprocessing's resource tracker
    children    start_child and run_child: one child, its answer within a timeout (every
                wait bounded: a stopped child or forkserver is killed), kill and reap;
                ChildNotStarted, ChildTimedOut, ChildDied (killed_from_outside: a SIGKILL
                not of its own limits, e.g. the OOM killer), killed_detail
    pools       HelperPool: long-lived spawned helpers behind a ProcessPoolExecutor, each
                call answered in time or the pool killed and replaced (HelperTimedOut)
    resident    ResidentHelper: one long-lived spawned helper answering messages on its pipe,
                each within a bounded wait, killed and restarted when it does not
    shared_files  SharedFile: an anonymous shared-memory file (memfd) handed to a helper,
                grown up to a bound and kept mapped, for answers too large for a pipe
    tracking    every live child and pool; shutdown(): stop them all (the app's lifespan,
                the test fixtures)
"""

from service.processes.children import (
    ChildDied,
    ChildNotStarted,
    ChildTimedOut,
    killed_detail,
    run_child,
    start_child,
)
from service.processes.cpu import STARVED_CPU_FRACTION, cpu_seconds, starved
from service.processes.limits import CHILD_NICENESS, ResourceLimits, forbid_file_writes
from service.processes.pools import HelperPool, HelperTimedOut
from service.processes.resident import ResidentHelper
from service.processes.shared_files import SharedFile
from service.processes.tracking import disown, end, live_children, own, shutdown
from service.processes.watchdog import die_with_supervisor

__all__ = [
    "CHILD_NICENESS",
    "STARVED_CPU_FRACTION",
    "ChildDied",
    "ChildNotStarted",
    "ChildTimedOut",
    "HelperPool",
    "HelperTimedOut",
    "ResidentHelper",
    "ResourceLimits",
    "SharedFile",
    "cpu_seconds",
    "die_with_supervisor",
    "disown",
    "end",
    "forbid_file_writes",
    "killed_detail",
    "live_children",
    "own",
    "run_child",
    "shutdown",
    "start_child",
    "starved",
]
