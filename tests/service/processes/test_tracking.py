"""`shutdown()` stops every process `service.processes` started (children, pool helpers, the
forkserver, the resource tracker), the app's lifespan calls it, and work started afterwards
starts them again."""

from __future__ import annotations

import os

import numpy as np
import orjson
from fastapi.testclient import TestClient

from service import processes
from service.main import create_app
from service.processes import HelperPool, ResourceLimits, live_children, run_child, start_child
from service.registry import Registry
from service.settings import Settings
from tests.descendants import descendants, wait_ended
from tests.service.dynamics.identification_logs import synthetic_log
from tests.service.processes import child_targets

PRELOAD = ("tests.service.processes.child_targets",)
END_S = 30.0


def _multiprocessing_processes(since: set[int] | None = None) -> dict[int, str]:
    """This process's descendants started by multiprocessing: the forkserver and its children
    (which share its command line), spawned children and helpers, the resource tracker. With
    `since` (the pids before the test), those started since then only: what earlier tests of
    the session started is theirs (the session's own check finds what any test leaves
    behind). An app's lifespan stops the shared forkserver and resource tracker, so a test
    that starts work starts them anew."""
    found = {pid: cmd for pid, cmd in descendants(os.getpid()).items() if "multiprocessing" in cmd}
    return found if since is None else {p: c for p, c in found.items() if p not in since}


def test_shutdown_stops_every_process_it_started_and_work_starts_them_again():
    before = set(_multiprocessing_processes())
    limits = ResourceLimits(niceness=0)
    forked, forked_conn = start_child(child_targets.sleep, (600,), limits=limits, preload=PRELOAD)
    spawned, spawned_conn = start_child(child_targets.sleep, (600,), limits=limits, start="spawn")
    pool = HelperPool(1, limits)
    assert pool.call(abs, -3) == 3
    started = _multiprocessing_processes(before)
    kinds = " ".join(_multiprocessing_processes().values())  # shared ones may be older
    assert "forkserver" in kinds and "spawn" in kinds and "resource_tracker" in kinds
    assert {forked.pid, spawned.pid} <= set(started)
    processes.shutdown()
    running = wait_ended(set(started), END_S)
    assert not running, {pid: started[pid] for pid in running}
    assert live_children() == []
    forked_conn.close()
    spawned_conn.close()
    # started again on demand
    assert pool.call(abs, -4) == 4
    assert (
        run_child(
            child_targets.reverse_bytes,
            timeout_s=60,
            limits=limits,
            preload=PRELOAD,
            send_bytes=b"ab",
        )
        == b"ba"
    )
    processes.shutdown()
    assert not wait_ended(set(_multiprocessing_processes(before)), END_S)


def test_the_end_of_an_apps_lifespan_stops_its_processes(tmp_path):
    """An upload read in a child (the forkserver starts), a large JSON body (the JSON helper
    starts), an identification (its worker starts): none is left once the app stops."""
    before = set(_multiprocessing_processes())
    registry = Registry(tmp_path, ["ur5"])
    registry.load()
    app = create_app(Settings(data_dir=tmp_path, catalog="ur5"), registry=registry)
    with TestClient(app, raise_server_exceptions=False) as client:
        large_upload = client.post("/v1/robots", json={"urdf": "<robot/>", "name": "x" * 2**21})
        assert large_upload.status_code == 422  # the name is too long: read in a child
        t = np.linspace(0.0, 20.0, 30_000)
        q = np.stack([0.4 * np.sin((j + 1) * 0.3 * t) for j in range(6)], axis=1).tolist()
        q[20_000][3] = "x"  # refused by the helper's validation
        large_json = client.post(
            "/v1/robots/ur5/trajectory-check",
            content=orjson.dumps({"t": t.tolist(), "q": q}),
            headers={"content-type": "application/json"},
        )
        assert large_json.status_code == 422
        log = synthetic_log(registry.get("ur5").model, seed=3, duration=4.0, rate=50.0)
        fit = client.post(
            "/v1/robots/ur5/identify",
            json={
                "t": log.t.tolist(),
                "q": log.q.tolist(),
                "tau": log.tau.tolist(),
                "method": "least-squares",
                "store": False,
            },
        )
        assert fit.status_code == 200, fit.text[:300]
        started = _multiprocessing_processes(before)
        kinds = " ".join(_multiprocessing_processes().values())  # shared ones may be older
        assert "forkserver" in kinds and "resource_tracker" in kinds
        assert sum("multiprocessing.spawn" in cmd for cmd in started.values()) == 2  # helpers
    running = wait_ended(set(started), END_S)
    assert not running, {pid: started[pid] for pid in running}
    assert live_children() == []
