"""One child process: its answer, its limits as the kernel sees them, its timeout (and whether
it was starved of CPU), its death, and that it is reaped whatever happened."""

from __future__ import annotations

import contextlib
import os
import resource
import signal
import threading
from multiprocessing import forkserver

import pytest

from service.processes import (
    CHILD_NICENESS,
    ChildDied,
    ChildNotStarted,
    ChildTimedOut,
    ResourceLimits,
    children,
    killed_detail,
    live_children,
    run_child,
)
from tests.descendants import descendants, wait_ended
from tests.service.processes import child_targets

PRELOAD = ("tests.service.processes.child_targets",)


def _run(
    target,
    *args,
    timeout_s: float = 60.0,
    limits: ResourceLimits | None = None,
    kill_after_s: float | None = None,
    **kw,
):
    """`run_child`; with `kill_after_s`, the child is killed by SIGKILL from outside then."""
    if kill_after_s is not None:
        before = {proc.pid for proc in live_children()}

        def kill_from_outside() -> None:
            for proc in live_children():
                if proc.pid not in before:
                    os.kill(proc.pid, signal.SIGKILL)

        threading.Timer(kill_after_s, kill_from_outside).start()
    return run_child(
        target, args, timeout_s=timeout_s, limits=limits or ResourceLimits(), preload=PRELOAD, **kw
    )


def _no_child_left() -> bool:
    """No child of this package tracked, and no forked child of the forkserver running."""
    return live_children() == [] and all(
        "forkserver" not in cmd or "from multiprocessing.forkserver import main" in cmd
        for cmd in descendants(os.getpid()).values()
    )


def test_the_child_is_limited_as_asked():
    limits = ResourceLimits(memory_mb=1536, cpu_s=7, open_files=32, niceness=CHILD_NICENESS)
    seen = _run(child_targets.report_limits, limits=limits)
    memory = 1536 * 1024 * 1024
    assert seen["as"] == (memory, memory)
    assert seen["cpu"] == (7, 8)  # SIGXCPU at 7 s, SIGKILL at 8 s
    assert seen["core"] == (0, 0)
    assert seen["nofile"] == (32, 32)
    assert seen["nice"] == min(os.nice(0) + CHILD_NICENESS, 19)
    unlimited = _run(child_targets.report_limits, limits=ResourceLimits(niceness=0))
    assert unlimited["as"] == resource.getrlimit(resource.RLIMIT_AS)
    assert unlimited["cpu"] == resource.getrlimit(resource.RLIMIT_CPU)
    assert unlimited["nice"] == os.nice(0)


def test_the_answer_comes_back_and_bytes_go_in():
    assert _run(child_targets.reverse_bytes, send_bytes=b"robodyn" * 1000) == b"nydobor" * 1000
    assert _no_child_left()


def test_a_child_over_its_memory_limit_gets_a_memory_error():
    # the limit is on the whole address space: 256 MB more than a child starts with
    limits = ResourceLimits(memory_mb=_run(child_targets.address_space_mb) + 256)
    assert _run(child_targets.allocate, 64, limits=limits).startswith("ok")
    assert _run(child_targets.allocate, 1024, limits=limits) == "memory error"


def test_a_child_without_an_answer_in_time_is_killed_and_was_starved_if_idle():
    with pytest.raises(ChildTimedOut) as timed_out:
        _run(child_targets.sleep, 120.0, timeout_s=1.0)
    # a sleeping child used (almost) no CPU: the machine's fault, not its work's
    assert timed_out.value.cpu_s is not None and timed_out.value.starved(1.0)
    assert _no_child_left()


def test_a_child_over_its_cpu_limit_dies_by_sigxcpu():
    with pytest.raises(ChildDied) as died:
        _run(child_targets.spin, limits=ResourceLimits(cpu_s=1))
    assert died.value.exitcode in (-signal.SIGXCPU, -signal.SIGKILL)
    assert _no_child_left()


def test_a_crash_is_a_death_with_its_signal():
    with pytest.raises(ChildDied) as died:
        _run(child_targets.crash)
    assert died.value.exitcode == -signal.SIGSEGV
    assert _no_child_left()


def test_a_child_that_stops_reading_is_killed_at_its_deadline():
    """A child that never reads the bytes sent to it (stopped, hung) would block the sending
    parent forever once the pipe is full: it is killed at its deadline instead."""
    with pytest.raises(ChildTimedOut) as timed_out:
        _run(child_targets.sleep, 600.0, timeout_s=1.0, send_bytes=b"x" * (16 * 1024 * 1024))
    assert timed_out.value.starved(1.0)  # it did nothing
    assert _no_child_left()


def test_a_stopped_forkserver_is_killed_and_the_next_child_gets_a_new_one(monkeypatch):
    _run(child_targets.report_limits)  # the forkserver runs
    stopped = forkserver._forkserver._forkserver_pid
    os.kill(stopped, signal.SIGSTOP)
    monkeypatch.setattr(children, "START_TIMEOUT_S", 1.0)
    try:
        with pytest.raises(ChildNotStarted):
            _run(child_targets.report_limits)
        assert not wait_ended({stopped}, 30.0)
        assert _run(child_targets.reverse_bytes, send_bytes=b"ab") == b"ba"
        assert forkserver._forkserver._forkserver_pid != stopped
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(stopped, signal.SIGKILL)
    assert _no_child_left()


def test_a_sigkill_is_told_from_the_childs_own_limits():
    """SIGKILL with CPU time left below the CPU limit comes from outside (the OOM killer);
    SIGXCPU and the hard SIGKILL at the limit are the child's own."""
    with pytest.raises(ChildDied) as died:
        _run(child_targets.sleep, 600.0, kill_after_s=0.5)
    assert died.value.exitcode == -signal.SIGKILL
    assert died.value.killed_from_outside(cpu_limit_s=20)
    assert died.value.killed_from_outside(cpu_limit_s=None)
    with pytest.raises(ChildDied) as over_its_limit:
        _run(child_targets.spin, limits=ResourceLimits(cpu_s=1))
    assert not over_its_limit.value.killed_from_outside(cpu_limit_s=1)
    assert "killed by signal 9 (SIGKILL)" in killed_detail("the builder", -signal.SIGKILL)
