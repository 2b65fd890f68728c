"""Build contention: uploads are validated and built in builder processes,
at most the CPU count at once; the serving process keeps answering while heavy uploads are
built; waiting for a builder, or a build starved of CPU, is 503 `overloaded` with
Retry-After, never a false 422 `invalid_model`."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx
import numpy as np
import pytest
from fastapi.testclient import TestClient

from service import CPUS
from service.errors import InvalidModel, Overloaded
from service.main import create_app
from service.processes import cpu_seconds
from service.registry import Registry
from service.registry.build_process import _timed_out
from service.registry.build_slots import BuildSlots, build_slot_count
from service.settings import Settings


def heavy_mjcf(i: int, sites: int = 20_000) -> str:
    """A valid one-joint MJCF with `sites` sites (each upload different; 0.75 MB for 20,000):
    on one core about 1.5 s of XML validation and 3–4 s of native parsing."""
    s = "".join(f'<site name="s{k}" pos="{i}.{k} 0 0"/>' for k in range(sites))
    return (
        f'<mujoco model="heavy{i}"><compiler angle="radian"/><worldbody><body name="arm">'
        '<joint name="shoulder" type="hinge" axis="0 -1 0" range="-3 3"/>'
        f'<inertial pos="1 0 0" mass="2" diaginertia="0.1 0.1 0.1"/>{s}</body></worldbody>'
        "</mujoco>"
    )


def _session_processes(session: int) -> list[tuple[int, int, str]]:
    """(pid, ppid, command line) of every process of a session."""
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_bytes().rsplit(b")", 1)[1].split()
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue
        if int(stat[3]) == session:  # fields after "(comm)": state ppid pgrp session ...
            out.append((int(entry.name), int(stat[1]), cmdline))
    return out


def builder_count(server_pid: int) -> int:
    """Builder processes of a server: forked by its forkserver (they share its command line),
    the forkserver itself (a child of the server) not counted."""
    return sum(
        1
        for pid, ppid, cmd in _session_processes(server_pid)
        if "forkserver" in cmd and ppid != server_pid
    )


PROBE = """
import json, sys, time, httpx
latencies = []
with httpx.Client(base_url=sys.argv[1], timeout=10) as client:
    while True:
        started = time.perf_counter()
        assert client.get("/health/live").status_code == 200
        latencies.append(time.perf_counter() - started)
        time.sleep(0.02)
        if len(latencies) % 5 == 0 and open(sys.argv[2]).read():
            break
print(json.dumps(latencies))
"""


@pytest.mark.slow  # a latency bound under eight builds: in the slow suite with the other probes
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_heavy_concurrent_uploads_keep_the_server_live_and_builders_bounded(
    server_factory, tmp_path
):
    server = server_factory(catalog="planar_arm").start()
    assert server.proc is not None
    bodies = [{"mjcf": heavy_mjcf(i)} for i in range(8)]
    most_builders = 0
    done = threading.Event()
    stop = tmp_path / "stop-probe"
    stop.write_text("")
    # /health/live is probed from its own process, so that the uploading threads of this one
    # (encoding bodies, reading answers) cannot delay the probe's own measurement
    probe = subprocess.Popen(
        [sys.executable, "-c", PROBE, server.base, str(stop)], stdout=subprocess.PIPE, text=True
    )

    def count() -> None:
        nonlocal most_builders
        while not done.is_set():
            most_builders = max(most_builders, builder_count(server.proc.pid))
            time.sleep(0.05)

    def upload(body: dict) -> httpx.Response:
        return httpx.post(server.base + "/v1/robots", json=body, timeout=180)

    counter = threading.Thread(target=count)
    counter.start()
    try:
        time.sleep(0.5)
        with ThreadPoolExecutor(len(bodies)) as pool:
            answers = list(pool.map(upload, bodies))
    finally:
        done.set()
        counter.join()
        stop.write_text("stop")
        out, _ = probe.communicate(timeout=60)
    statuses = [r.status_code for r in answers]
    for r in answers:
        assert r.status_code in (201, 503), r.text
        if r.status_code == 503:  # the machine's contention: overloaded, never invalid_model
            assert r.json()["code"] == "overloaded" and r.headers["Retry-After"]
    assert statuses.count(201) >= 1, statuses
    assert 1 <= most_builders <= max(1, len(CPUS)), most_builders
    lat = np.array(json.loads(out))
    assert len(lat) > 20
    assert np.percentile(lat, 99) < 0.25 and lat.max() < 0.5, (
        f"/health/live p99 {np.percentile(lat, 99):.3f} s, max {lat.max():.3f} s"
    )


def test_uploads_beyond_the_builders_and_the_wait_are_503_overloaded(tmp_path):
    registry = Registry(tmp_path, ["planar_arm"], build_slots=BuildSlots(1, 0.3))
    registry.load()
    app = create_app(Settings(data_dir=tmp_path), registry=registry)
    with TestClient(app, raise_server_exceptions=False) as client, ThreadPoolExecutor(3) as pool:
        answers = list(
            pool.map(
                lambda i: client.post("/v1/robots", json={"mjcf": heavy_mjcf(i, 8000)}), range(3)
            )
        )
    statuses = sorted(r.status_code for r in answers)
    assert statuses[0] == 201 and 503 in statuses, statuses
    for r in answers:
        if r.status_code == 503:
            problem = r.json()
            assert problem["code"] == "overloaded" and r.headers["Retry-After"]
            assert "ROBODYN_MAX_CONCURRENT_BUILDS" in problem["detail"]


def test_too_many_waiting_builds_are_refused_at_once():
    slots = BuildSlots(1, 5.0, max_waiting=1)
    release = threading.Event()

    def hold() -> None:
        with slots.slot():
            release.wait(5)

    holder = threading.Thread(target=hold)
    holder.start()
    while slots.building == 0:
        time.sleep(0.01)
    waiter = threading.Thread(target=hold)
    waiter.start()
    while slots.waiting == 0:
        time.sleep(0.01)
    started = time.perf_counter()
    with pytest.raises(Overloaded, match="1 are waiting"), slots.slot():
        pass
    assert time.perf_counter() - started < 2.5  # refused at once, not after the 5 s wait
    release.set()
    holder.join()
    waiter.join()
    assert slots.building == slots.waiting == 0


def test_build_slots_are_at_most_the_cpu_count():
    cpus = max(1, len(CPUS))
    assert build_slot_count(0) == cpus
    assert build_slot_count(10_000) == cpus
    assert build_slot_count(1) == 1


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_a_timed_out_build_is_invalid_only_if_it_had_the_cpu():
    """A child that used its time on a CPU and still did not finish: invalid_model. A child
    that hardly ran (starved by the machine's load): overloaded."""
    idle = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(1.5)
        assert isinstance(_timed_out(cpu_seconds(idle.pid), 1.0), Overloaded)
        cpu_busy = _timed_out(cpu_seconds(busy.pid), 1.0)
        # on a loaded machine the busy child may itself have been starved; it then is not
        # the model's fault either
        assert isinstance(cpu_busy, InvalidModel | Overloaded)
        assert isinstance(_timed_out(cpu_seconds(busy.pid), 0.2), InvalidModel)
        assert "ROBODYN_BUILD_TIMEOUT_S" in str(_timed_out(cpu_seconds(idle.pid), 1.0))
    finally:
        for proc in (idle, busy):
            proc.kill()
            proc.wait()
