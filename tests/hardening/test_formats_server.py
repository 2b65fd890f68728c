"""Slow: MJCF and xacro uploads against a real server (`python -m service`): while hostile xacro
runs into the builder's limits or its confinement, while a large MJCF with 173 meshes is
compiled, and while a 44 MB XML asset is refused, /health/live keeps answering within 0.5 s,
and the server stays alive. The 44 MB XML asset is never parsed by the serving process: its
peak memory stays far below the ~1.4 GB a tree of it took."""

from __future__ import annotations

import base64
import threading
from pathlib import Path

import httpx
import pytest

from tests.hardening.corpus import arm
from tests.hardening.test_corpus_server import _health_latencies
from tests.service.registry.mjcf_reference import DM_SUITE, directory_assets, encoded
from tests.service.registry.test_xacro import HOSTILE, MARKER

pytestmark = pytest.mark.slow

CASES = {
    "xacro CPU bomb": ({"xacro": HOSTILE["CPU bomb"][0]}, "CPU limit"),
    "xacro memory bomb": ({"xacro": HOSTILE["memory bomb"][0]}, "memory limit"),
    "xacro escape to os.system": ({"xacro": HOSTILE["os.system via an escape"][0]}, "'os.system'"),
    "xacro reading /etc/passwd": ({"xacro": HOSTILE["YAML from a system file"][0]}, "/etc/passwd"),
    "MJCF dog with its meshes": (
        {
            "mjcf": (DM_SUITE / "dog.xml").read_text(),
            "assets": encoded(directory_assets(DM_SUITE, "common", "dog_assets")),
        },
        None,
    ),
}


def _peak_rss_mb(pid: int) -> float:
    """The peak resident memory of a process (VmHWM), MB."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    raise AssertionError("no VmHWM")


def test_a_44_mb_xml_asset_is_read_only_by_the_builder(server_factory) -> None:
    """A 60 MB upload whose 44 MB `.xml` asset has 11 million elements: a 422 naming the asset
    and the element cap; the serving process's peak memory grows by much less than a tree of
    it would take (~1.4 GB), and /health/live keeps answering."""
    server = server_factory().start()
    assert server.proc is not None
    before = _peak_rss_mb(server.proc.pid)
    xml = b"<m>" + b"<a/>" * 11_000_000 + b"</m>"
    body = {"urdf": arm(), "assets": {"part.xml": base64.b64encode(xml).decode()}}
    del xml
    latencies: list[float] = []
    stop = threading.Event()
    watcher = threading.Thread(target=_health_latencies, args=(server.base, stop, latencies))
    watcher.start()
    try:
        r = httpx.post(f"{server.base}/v1/robots", json=body, timeout=120)
    finally:
        stop.set()
        watcher.join(30)
    assert r.status_code == 422 and r.json()["code"] == "invalid_model", r.text
    assert "'part.xml' is unreadable as .xml: it has more than 50000" in r.json()["detail"]
    growth = _peak_rss_mb(server.proc.pid) - before
    assert growth < 700, f"the serving process grew by {growth:.0f} MB"
    assert server.alive()
    assert len(latencies) >= 3 and max(latencies) < 0.5, latencies


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
