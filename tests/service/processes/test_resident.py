"""A resident helper answers messages on its pipe and writes into a shared file the serving
process reads; one that ends or does not answer in time is stopped (killed, reaped, forgotten)
and the next `start()` starts a new one; nothing of it outlives `shutdown()`."""

from __future__ import annotations

import os
import signal
import time

import pytest

from service import processes
from service.processes import (
    ChildDied,
    ChildTimedOut,
    ResidentHelper,
    ResourceLimits,
    SharedFile,
    live_children,
)
from tests.descendants import wait_ended
from tests.service.processes import child_targets

READY_S = 60.0  # a spawned interpreter imports its modules first (seconds on a busy machine)
END_S = 30.0


def _started(helper: ResidentHelper, file: SharedFile) -> None:
    helper.start()
    helper.send_handle(file.fd)
    deadline = time.monotonic() + READY_S
    while not helper.ready():
        assert time.monotonic() < deadline, "the helper did not say it was ready"
        time.sleep(0.05)


def _memfds(pid: int) -> list[str]:
    """The anonymous shared files a process holds open or mapped (/proc)."""
    found = []
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if target.startswith("/memfd:robodyn-test"):
            found.append(target)
    with open(f"/proc/{pid}/maps") as fh:
        found += [line for line in fh if "/memfd:robodyn-test" in line]
    return found


@pytest.fixture
def shared():
    helper = ResidentHelper(child_targets.serve_shared_file, ResourceLimits(niceness=0))
    file = SharedFile(4 << 20, "robodyn-test")
    yield helper, file
    helper.close()
    file.close()


def test_the_helper_writes_into_the_file_the_parent_reads(shared):
    helper, file = shared
    assert file.reserve(3 << 20)
    assert file.size >= 3 << 20 and file.map is not None
    _started(helper, file)
    data = os.urandom(1 << 20)
    assert helper.ask((file.size, 12345, data), 30.0) == len(data)
    assert file.map[12345 : 12345 + len(data)] == data
    # grown later: the helper maps the file at its new size
    assert file.reserve(4 << 20) and not file.reserve((4 << 20) + 1)
    assert helper.ask((file.size, (4 << 20) - 3, b"end"), 30.0) == 3
    assert file.map[(4 << 20) - 3 :] == b"end"


def test_a_killed_helper_is_stopped_and_a_new_one_serves(shared):
    helper, file = shared
    assert file.reserve(1 << 20)
    _started(helper, file)
    first = helper.proc
    assert first is not None and first.pid is not None
    os.kill(first.pid, signal.SIGKILL)
    with pytest.raises(ChildDied) as died:
        helper.ask((file.size, 0, b"x"), 30.0)
    assert died.value.exitcode == -signal.SIGKILL
    assert helper.proc is None and first not in live_children()
    _started(helper, file)  # a new helper, handed the same file
    assert helper.proc is not first
    assert helper.ask((file.size, 0, b"again"), 30.0) == 5
    assert file.map is not None and file.map[:5] == b"again"


def test_a_helper_that_does_not_answer_in_time_is_killed(shared):
    helper, file = shared
    assert file.reserve(1 << 20)
    _started(helper, file)
    proc = helper.proc
    assert proc is not None and proc.pid is not None
    started = time.monotonic()
    with pytest.raises(ChildTimedOut):
        helper.ask(("sleep", 60.0), 0.5)
    assert time.monotonic() - started < 30.0
    assert not wait_ended([proc.pid], END_S)  # killed and reaped, not left sleeping
    assert helper.proc is None and proc not in live_children()


def test_shutdown_leaves_no_helper_and_no_shared_memory(shared):
    helper, file = shared
    assert file.reserve(1 << 20)
    _started(helper, file)
    assert helper.ask((file.size, 0, b"mapped"), 30.0) == 6
    proc = helper.proc
    assert proc is not None and proc.pid is not None
    processes.shutdown()
    assert not wait_ended([proc.pid], END_S)
    assert helper.proc is None
    file.close()
    assert _memfds(os.getpid()) == []  # nothing of it left in this process either
