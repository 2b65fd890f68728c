"""Slow: MJCF and xacro uploads against a real server (`python -m service`): while hostile xacro
runs into the builder's limits or its confinement, and while a large MJCF with 173 meshes is
compiled, /health/live keeps answering within 0.5 s, and the server stays alive."""

from __future__ import annotations

import threading

import httpx
import pytest

from tests.hardening.test_corpus_server import _health_latencies
from tests.service.mjcf_reference import DM_SUITE, directory_assets, encoded
from tests.service.test_xacro import HOSTILE, MARKER

pytestmark = pytest.mark.slow

CASES = {
    "xacro CPU bomb": ({"xacro": HOSTILE["CPU bomb"][0]}, "CPU limit"),
    "xacro memory bomb": ({"xacro": HOSTILE["memory bomb"][0]}, "memory limit"),
    "xacro escape to os.system": ({"xacro": HOSTILE["os.system via an escape"][0]},
                                  "'os.system'"),
    "xacro reading /etc/passwd": ({"xacro": HOSTILE["YAML from a system file"][0]},
                                  "/etc/passwd"),
    "MJCF dog with its meshes": ({"mjcf": (DM_SUITE / "dog.xml").read_text(),
                                  "assets": encoded(directory_assets(DM_SUITE, "common",
                                                                     "dog_assets"))}, None),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_format_uploads_keep_the_server_responsive(server_factory, case: str) -> None:
    body, fragment = CASES[case]
    server = server_factory(env={"ROBODYN_BUILD_CPU_S": "3"}).start()
    MARKER.unlink(missing_ok=True)
    latencies: list[float] = []
    stop = threading.Event()
    watcher = threading.Thread(target=_health_latencies, args=(server.base, stop, latencies))
    watcher.start()
    try:
        r = httpx.post(f"{server.base}/v1/robots", json=body, timeout=120)
    finally:
        stop.set()
        watcher.join(30)
    if fragment is None:
        assert r.status_code == 201, r.text
    else:
        assert r.status_code == 422 and r.json()["code"] == "invalid_model", r.text
        assert fragment in r.json()["detail"], r.json()["detail"]
    assert not MARKER.exists()
    assert server.alive()
    assert len(latencies) >= 3 and max(latencies) < 0.5, latencies
