"""A child dies with the process that started it: forked children, spawned children, pool
helpers, the forkserver and the resource tracker all end when their serving process is killed
(SIGKILL: no shutdown runs); and a spawned child does not die with the short-lived thread that
asked for it."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from service.processes import ResourceLimits, end, start_child
from tests.descendants import command_line, descendants, ended, wait_ended
from tests.service.processes import child_targets

REPO = Path(__file__).resolve().parents[3]
PARENT = """
import time
from service.processes import HelperPool, ResourceLimits, start_child
from tests.service.processes.child_targets import sleep

limits = ResourceLimits(niceness=0)
start_child(sleep, (600,), limits=limits, preload=("tests.service.processes.child_targets",))
start_child(sleep, (600,), limits=limits, start="spawn")
HelperPool(1, limits).call(int)
print("started", flush=True)
time.sleep(600)
"""
END_S = 60.0  # how long the children may take to end once their parent is killed

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux prctl")


def test_every_child_ends_when_its_parent_is_killed():
    parent = subprocess.Popen(
        [sys.executable, "-c", PARENT], cwd=REPO, stdout=subprocess.PIPE, text=True
    )
    children: dict[int, str] = {}
    try:  # the pipe is closed in `finally`
        assert parent.stdout is not None
        assert parent.stdout.readline().strip() == "started"
        children = descendants(parent.pid)
        commands = list(children.values())
        # the forkserver and its child (which shares its command line), the spawned child,
        # the pool's helper, the resource tracker
        assert sum("multiprocessing.forkserver" in cmd for cmd in commands) == 2, commands
        assert sum("multiprocessing.spawn" in cmd for cmd in commands) == 2, commands
        assert sum("multiprocessing.resource_tracker" in cmd for cmd in commands) == 1, commands
        parent.kill()  # SIGKILL: nothing of the parent runs any more
        parent.wait(30)
        running = wait_ended(set(children), END_S)
        assert not running, {pid: children[pid] for pid in running}
    finally:
        if parent.stdout is not None:
            parent.stdout.close()
        if parent.poll() is None:
            parent.kill()
            parent.wait(30)
        for pid, cmd in children.items():  # orphans of a failed test are not left behind
            if not ended(pid) and command_line(pid) == cmd:  # still the same process
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)


def test_a_spawned_child_outlives_the_thread_that_started_it():
    """PDEATHSIG fires when the thread that started the child ends: spawned children are
    started from the launcher thread, not from the caller's (a server's worker thread ends
    after a while idle)."""
    started = []

    def start() -> None:
        proc, conn = start_child(
            child_targets.ready_then_sleep,
            (600,),
            limits=ResourceLimits(niceness=0),
            start="spawn",
        )
        started.append((proc, conn))
        assert conn.recv() == "ready"  # the child's watchdog is set

    thread = threading.Thread(target=start)
    thread.start()
    thread.join(120)
    proc, conn = started[0]
    try:
        time.sleep(0.5)  # a PDEATHSIG tied to the ended thread would have killed it by now
        assert proc.is_alive()
    finally:
        conn.close()
        end(proc)
