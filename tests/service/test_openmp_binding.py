"""`python -m service` binds its OpenMP team (OMP_PROC_BIND) so that a batch keeps one core per
thread, while the event loop's thread keeps every CPU: after a parallel batch the team's master
and worker threads are each bound to their own CPU, and the main thread to all of them."""

from __future__ import annotations

import os
from pathlib import Path

import httpx
import numpy as np
import pytest

from tests.servers import running_server

CPUS = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else set()


def _pid_listening_on(port: int) -> int:
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                args = (entry / "cmdline").read_bytes().split(b"\0")
            except OSError:
                continue
            if b"service" in args and str(port).encode() in args:
                return int(entry.name)
    raise AssertionError(f"no server process on port {port}")


def _allowed_cpus(pid: int) -> dict[int, set[int]]:
    out = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            status = (task / "status").read_text()
        except OSError:
            continue  # a thread that just ended
        listed = status.split("Cpus_allowed_list:")[1].split()[0]
        cpus: set[int] = set()
        for part in listed.split(","):
            low, _, high = part.partition("-")
            cpus.update(range(int(low), int(high or low) + 1))
        out[int(task.name)] = cpus
    return out


@pytest.mark.skipif(
    len(CPUS) < 2 or not Path("/proc/self/task").exists(), reason="needs Linux and at least 2 CPUs"
)
def test_the_team_is_bound_and_the_event_loop_is_not(tmp_path: Path) -> None:
    with running_server(tmp_path, CATALOG="ur5") as url:
        q = np.tile([0.1, -1.2, 1.3, 0.2, 0.5, -0.3], (200, 1))  # ≥ 64 states: parallel
        r = httpx.post(
            f"{url}/v1/robots/ur5/inverse-dynamics",
            json={"q": q.tolist(), "v": q.tolist(), "a": q.tolist()},
            timeout=60,
        )
        assert r.status_code == 200
        pid = _pid_listening_on(int(url.rsplit(":", 1)[1]))
        allowed = _allowed_cpus(pid)
    assert allowed[pid] == CPUS  # the event loop's thread: every CPU again
    bound = sorted(next(iter(c)) for c in allowed.values() if len(c) == 1)
    assert bound == sorted(CPUS)  # master and workers: one CPU each, all different
