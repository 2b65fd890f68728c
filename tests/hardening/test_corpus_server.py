"""The hostile corpus against a real server (`python -m service`): the process stays alive, its
health endpoint keeps answering quickly while uploads are built, and an earlier upload is still
served after every case. Also the builder's limits, seen from outside: a build that runs into the
wall-clock timeout or the memory limit is a 422 while /health/live answers throughout."""

from __future__ import annotations

import threading
import time

import httpx
import numpy as np
import pytest

from tests.hardening.corpus import CASES, chain
from tests.hardening.test_corpus import SENTINEL, check_answer
from tests.helpers import planar_arm_closed_form

pytestmark = pytest.mark.slow


def test_corpus_against_a_real_server(server_factory):
    server = server_factory().start()
    with httpx.Client(base_url=server.base, timeout=60) as http:
        sentinel = http.post("/v1/robots", json={"urdf": SENTINEL})
        assert sentinel.status_code == 201, sentinel.text
        robot_id = sentinel.json()["id"]
        q = [0.3, -0.2]
        expected, _, _ = planar_arm_closed_form(0.7, 0.5, 1.5, 0.5, np.array(q), np.zeros(2))
        for case in CASES:
            r = http.post(
                "/v1/robots", content=case.content(), headers={"content-type": "application/json"}
            )
            check_answer(case, r)
            assert server.alive(), (case.id, server.log_text()[-2000:])
            assert http.get("/health/live").status_code == 200, case.id
            M = http.post(f"/v1/robots/{robot_id}/mass-matrix", json={"q": q})
            assert M.status_code == 200, (case.id, M.text)
            np.testing.assert_allclose(M.json()["mass_matrix"], expected, rtol=1e-10)
    assert "Traceback" not in server.log_text()


def _health_latencies(base: str, stop: threading.Event, out: list[float]) -> None:
    with httpx.Client(base_url=base, timeout=10) as http:
        while not stop.is_set():
            started = time.perf_counter()
            assert http.get("/health/live").status_code == 200
            out.append(time.perf_counter() - started)
            time.sleep(0.05)


@pytest.mark.parametrize(
    "env, fragment",
    [
        # nv = 300 passes the (raised) nv cap; createData then needs ~1.7 GB and ~2 s
        (
            {
                "ROBODYN_MAX_NV": "400",
                "ROBODYN_BUILD_TIMEOUT_S": "1",
                "ROBODYN_BUILD_MEMORY_MB": "4096",
            },
            "took longer than 1 s",
        ),
        ({"ROBODYN_MAX_NV": "400", "ROBODYN_BUILD_MEMORY_MB": "512"}, "memory limit of 512 MB"),
        (
            {
                "ROBODYN_MAX_NV": "400",
                "ROBODYN_BUILD_MEMORY_MB": "4096",
                "ROBODYN_BUILD_CPU_S": "1",
            },
            "CPU limit of 1 s",
        ),
    ],
    ids=["wall-clock", "memory", "cpu"],
)
def test_builder_limits_keep_the_server_responsive(server_factory, env, fragment):
    server = server_factory(env=env).start()
    latencies: list[float] = []
    stop = threading.Event()
    watcher = threading.Thread(target=_health_latencies, args=(server.base, stop, latencies))
    watcher.start()
    try:
        r = httpx.post(f"{server.base}/v1/robots", json={"urdf": chain(300, flat=True)}, timeout=60)
    finally:
        stop.set()
        watcher.join(30)
    assert r.status_code == 422 and r.json()["code"] == "invalid_model", r.text
    assert fragment in r.json()["detail"], r.json()["detail"]
    assert server.alive()
    assert len(latencies) >= 5 and max(latencies) < 0.5, latencies
    ok = httpx.post(f"{server.base}/v1/robots", json={"urdf": SENTINEL}, timeout=60)
    assert ok.status_code == 201, ok.text
