"""Noise in the signals operators alert on, against a real `python -m service`: a client that
disconnects in the middle of its body is counted under status 499 (never 500) and logged
without a traceback; what native libraries write to stderr (urdfdom, when a stored record fails
to rebuild) arrives as JSON lines like every other log record."""

from __future__ import annotations

import json
import re
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from service.registry.store import ModelStore
from tests.hardening.raw_http import connect, request
from tests.servers import running_server

BROKEN_URDF = (
    "<robot name='broken'><link name='a'/><joint name='j' type='revolute'>"
    "<parent link='a'/><child link='missing'/><axis xyz='0 0 1'/>"
    "<limit effort='1' velocity='1' lower='0' upper='1'/></joint></robot>"
)


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, Path]]:
    data = tmp_path_factory.mktemp("disconnects")
    # A stored record whose description makes urdfdom print to stderr when it is rebuilt on
    # its first use (as a record edited by hand might).
    ModelStore(data).write(
        {
            "id": "u-000000000000000000000bad",
            "format": "urdf",
            "description": BROKEN_URDF,
            "root_joint": "fixed",
            "gravity": [0.0, 0.0, -9.81],
            "name": "broken",
            "summary": {
                "id": "u-000000000000000000000bad",
                "name": "broken",
                "source": "upload",
                "nq": 1,
                "nv": 1,
                "root_joint": "fixed",
            },
        }
    )
    with running_server(data, catalog="ur5", log_level="info") as url:
        yield url, data / "server.log"


def _count(base: str, route: str, status: int) -> float:
    text = httpx.get(base + "/metrics").text
    total = 0.0
    for line in text.splitlines():
        if (
            line.startswith("robodyn_requests_total{")
            and f'route="{route}"' in line
            and f'status="{status}"' in line
        ):
            total += float(line.rsplit(" ", 1)[1])
    return total


def _disconnect_mid_body(base: str, path: str) -> None:
    with connect(base) as sock:
        sock.sendall(request("POST", path, b'{"q": [0, 0', content_length=10_000))
        time.sleep(0.2)  # the server is waiting for the rest


@pytest.mark.parametrize(
    "path, route",
    [
        ("/v1/robots/ur5/gravity", "/v1/robots/{robot_id}/gravity"),  # the lean dynamics path
        ("/v1/robots", "/v1/robots"),  # a framework route (upload)
    ],
)
def test_a_client_leaving_mid_body_is_a_499_not_a_500(server, path: str, route: str) -> None:
    base, log = server
    before = _count(base, route, 499)
    for _ in range(3):
        _disconnect_mid_body(base, path)
    deadline = time.monotonic() + 10
    while _count(base, route, 499) < before + 3:
        assert time.monotonic() < deadline, httpx.get(base + "/metrics").text[-3000:]
        time.sleep(0.1)
    assert _count(base, route, 500) == 0
    assert _count(base, route, 422) == 0  # nor mistaken for a malformed body
    records = [json.loads(line) for line in log.read_text().splitlines() if line.strip()]
    serving = [r for r in records if r["logger"] != "robodyn.registry"]  # (the bad record)
    assert not [r for r in serving if r["level"] in ("error", "critical")], serving[-5:]
    assert not [r for r in records if "exc" in r or "Traceback" in r["message"]]
    left = [r for r in records if "disconnected" in r["message"] and r.get("route") != route]
    assert any(r["level"] == "info" for r in left)


def test_native_stderr_becomes_json_lines(server) -> None:
    base, log = server
    assert httpx.get(base + "/health/ready").status_code == 200
    broken = httpx.get(base + "/v1/robots/u-000000000000000000000bad")  # rebuilt: urdfdom prints
    assert broken.status_code == 404 and "could not be rebuilt" in broken.json()["detail"]
    deadline = time.monotonic() + 30
    while "Failed to build tree" not in log.read_text() and time.monotonic() < deadline:
        time.sleep(0.05)  # the native stream is read by a thread of the server
    lines = [line for line in log.read_text().splitlines() if line.strip()]
    for line in lines:  # every line of the server's stderr is one JSON object
        record = json.loads(line)
        assert isinstance(record, dict) and {"ts", "level", "logger", "message"} <= set(record)
    native = [json.loads(line) for line in lines if '"robodyn.native"' in line]
    assert any(re.search(r"Failed to build tree", r["message"]) for r in native), native
    assert all(r["level"] == "warning" for r in native)
