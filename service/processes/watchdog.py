"""A child ends when the process that started it ends.

`die_with_parent` runs first in every child of this package (`children`, `pools`), before its
limits and its work:

- Linux's `prctl(PR_SET_PDEATHSIG, SIGKILL)`: the kernel kills the child when the thread that
  started it ends. That thread is the forkserver's only thread for a forked child, and the
  launcher thread (`contexts.launch`, alive as long as the serving process or until
  `shutdown`) for a spawned one, never a short-lived worker thread of the server.
- A forked child closes its copy of the forkserver's "alive" pipe: the forkserver ends when
  every holder of that pipe has closed it, so it now ends with the serving process instead of
  waiting for its children, and its children follow it by their PDEATHSIG.
- If the serving process is already gone when the child gets here, the child ends at once.

The chain: the serving process ends (even by SIGKILL) → the forkserver reads the end of its
alive pipe and exits → the kernel kills its children; spawned children are killed with the
launcher thread. Elsewhere than Linux only the last check runs.

`die_with_supervisor` does the same for a serving process itself when a supervisor started it
(`python -m service --workers N`: uvicorn's supervisor spawns the N serving processes from its
main thread): a SIGKILL of the supervisor then ends its serving processes, and with them their
children, instead of leaving them serving on the port.
"""

from __future__ import annotations

import ctypes
import multiprocessing as mp
import os
import signal
import sys
from multiprocessing import forkserver

PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def die_with_parent() -> None:
    """In a child just started: be killed when its parent ends (see the module docstring)."""
    _leave_forkserver_alive_pipe()
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    parent = mp.parent_process()
    if parent is not None and not parent.is_alive():  # it ended before the prctl
        os.kill(os.getpid(), signal.SIGKILL)


def _leave_forkserver_alive_pipe() -> None:
    """Close a forked child's copy of the write end of the forkserver's alive pipe (the
    forkserver's own bookkeeping; a spawned child has none)."""
    server = forkserver._forkserver
    fd = getattr(server, "_forkserver_alive_fd", None)
    if fd is not None:
        os.close(fd)
        server._forkserver_alive_fd = None  # type: ignore[attr-defined]


def die_with_supervisor() -> None:
    """In a serving process: be killed when the supervisor that spawned it ends (nothing when
    the serving process was not started by multiprocessing, e.g. `--workers 1`)."""
    if mp.parent_process() is not None:
        die_with_parent()
