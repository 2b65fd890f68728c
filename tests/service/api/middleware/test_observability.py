"""Observability: X-Request-ID, Server-Timing, the JSON access log, metrics by route and robot,
and the log level from the environment."""

from __future__ import annotations

import io
import json
import logging
import os
import re
import subprocess
import sys
import time

import httpx
import numpy as np
import pytest

from service import dynamics
from service.logs import (
    JSONFormatter,
    JSONLineHandler,
    configure_logging,
    parse_level,
    sole_json_handler,
)
from tests.helpers import planar_arm_urdf

Q_UR5 = [0.1, -1.2, 1.4, 0.3, -0.5, 0.7]


@pytest.fixture
def json_log():
    """Route every log record through the service's JSON handler into a buffer (then restore)."""
    root = logging.getLogger()
    saved = root.handlers[:], root.level
    buffer = io.StringIO()
    configure_logging("debug", stream=buffer)

    def lines() -> list[dict]:
        return [json.loads(line) for line in buffer.getvalue().splitlines()]

    yield lines
    for handler in root.handlers[:]:
        if handler not in saved[0]:
            root.removeHandler(handler)
    root.setLevel(saved[1])


def _timings(header: str) -> dict[str, float]:
    out = {}
    for part in header.split(","):
        name, _, dur = part.strip().partition(";dur=")
        out[name] = float(dur)
    return out


def test_request_id_is_generated_unique_and_returned(api):
    ids = {api.get("/health/live").headers["x-request-id"] for _ in range(5)}
    assert len(ids) == 5 and all(re.fullmatch(r"[0-9a-f]{32}", i) for i in ids)


def test_request_id_is_accepted_when_safe_and_replaced_otherwise(api):
    given = "client-42.retry:1"
    r = api.post("/v1/robots/ur5/gravity", json={"q": Q_UR5}, headers={"X-Request-ID": given})
    assert r.status_code == 200 and r.headers["x-request-id"] == given
    for bad in ("has space", "x" * 129, 'quote"d', ""):
        got = api.get("/health/live", headers={"X-Request-ID": bad}).headers["x-request-id"]
        assert got != bad and re.fullmatch(r"[0-9a-f]{32}", got)
    # Errors carry it too.
    r = api.post("/v1/robots/ur5/gravity", json={"q": [0]}, headers={"X-Request-ID": given})
    assert r.status_code == 422 and r.headers["x-request-id"] == given


def test_server_timing_reports_compute_within_the_request(api):
    q = np.tile(Q_UR5, (500, 1)).tolist()  # a batch large enough to be computed off the loop
    for body in ({"q": Q_UR5}, {"q": q}):
        r = api.post("/v1/robots/ur5/mass-matrix", json=body)
        assert r.status_code == 200
        timings = _timings(r.headers["server-timing"])
        assert set(timings) == {"compute", "app"}
        assert 0 <= timings["compute"] <= timings["app"]  # in ms, to the microsecond
    assert timings["compute"] > 0  # 500 mass matrices take more than a microsecond
    timings = _timings(api.get("/v1/robots/ur5").headers["server-timing"])
    assert set(timings) == {"app"}  # no computation: no compute entry


def test_access_log_line_says_what_the_request_did(api, json_log):
    q = np.tile(Q_UR5, (3, 1)).tolist()
    api.post(
        "/v1/robots/ur5/inverse-dynamics",
        json={"q": q, "v": q, "a": q},
        headers={"X-Request-ID": "batch-1"},
    )
    api.post("/v1/robots/ur5/gravity", json={"q": [0, 0]}, headers={"X-Request-ID": "bad-1"})
    api.get("/v1/robots/nope", headers={"X-Request-ID": "missing-1"})
    api.get("/health/ready", headers={"X-Request-ID": "probe-1"})
    lines = {line["request_id"]: line for line in json_log() if line["logger"] == "robodyn.access"}
    batch = lines["batch-1"]
    assert batch["level"] == "info" and batch["method"] == "POST"
    assert batch["route"] == "/v1/robots/{robot_id}/inverse-dynamics"
    assert (batch["robot"], batch["quantity"], batch["batch_size"], batch["status"]) == (
        "ur5",
        "inverse-dynamics",
        3,
        200,
    )
    assert isinstance(batch["compute_ms"], float)
    assert 0 <= batch["compute_ms"] <= batch["duration_ms"]
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z", batch["ts"])
    bad = lines["bad-1"]
    assert (bad["robot"], bad["status"], bad["quantity"], bad["compute_ms"]) == (
        "ur5",
        422,
        None,
        None,
    )
    assert lines["missing-1"]["status"] == 404 and lines["missing-1"]["robot"] == "nope"
    assert lines["probe-1"]["level"] == "debug"  # probes and scrapes stay out of the info log


def test_no_access_line_is_built_when_info_is_disabled(api, json_log):
    logging.getLogger().setLevel(logging.WARNING)
    api.post("/v1/robots/ur5/gravity", json={"q": Q_UR5})
    assert not [line for line in json_log() if line["logger"] == "robodyn.access"]


def _sample(text: str, name: str, **labels: str) -> float:
    for line in text.splitlines():
        if line.startswith(name + "{") and all(f'{k}="{v}"' in line for k, v in labels.items()):
            return float(line.rsplit(" ", 1)[1])
    return 0.0


def test_metrics_histograms_by_route_and_robot(api):
    before = api.get("/metrics").text
    api.post("/v1/robots/panda/mass-matrix", json={"q": [[0.0] * 9] * 4})
    api.post("/v1/robots/panda/mass-matrix", json={"q": [0.0] * 9})
    after = api.get("/metrics").text
    route = "/v1/robots/{robot_id}/mass-matrix"

    def delta(name, **labels):
        return _sample(after, name, **labels) - _sample(before, name, **labels)

    assert delta("robodyn_request_duration_seconds_count", route=route, robot="panda") == 2
    assert delta("robodyn_compute_seconds_count", quantity="mass-matrix", robot="panda") == 2
    assert delta("robodyn_batch_size_sum", quantity="mass-matrix") == 5
    assert delta("robodyn_batch_size_bucket", quantity="mass-matrix", le="1.0") == 1
    compute = delta("robodyn_compute_seconds_sum", quantity="mass-matrix", robot="panda")
    total = delta("robodyn_request_duration_seconds_sum", route=route, robot="panda")
    assert 0 < compute < total


def test_robot_label_cardinality_is_bounded(api, tmp_path):
    for i in range(5):
        api.post(f"/v1/robots/made-up-{i}/gravity", json={"q": [0]})
    upload = api.post("/v1/robots", json={"urdf": planar_arm_urdf(1.0, 0.5, 1.0, 2.0)}).json()
    api.post(f"/v1/robots/{upload['id']}/gravity", json={"q": [0.1, 0.2]})
    text = api.get("/metrics").text
    assert "made-up" not in text and upload["id"] not in text
    route = "/v1/robots/{robot_id}/gravity"
    assert _sample(text, "robodyn_requests_total", route=route, robot="unknown", status="404") >= 5
    assert _sample(text, "robodyn_requests_total", route=route, robot="upload", status="200") >= 1


def test_an_unexpected_failure_is_a_500_with_request_id_and_a_correlated_log(
    small_app_factory, monkeypatch, json_log
):
    client = small_app_factory(catalog="ur5")

    def broken(*args, **kwargs):
        raise RuntimeError("bug")

    monkeypatch.setattr(dynamics, "run", broken)
    r = client.post(
        "/v1/robots/ur5/gravity", json={"q": Q_UR5}, headers={"X-Request-ID": "crash-1"}
    )
    assert r.status_code == 500 and r.json()["code"] == "internal_error"
    assert r.headers["x-request-id"] == "crash-1"
    assert "bug" not in r.text and "Traceback" not in r.text
    lines = [line for line in json_log() if line.get("request_id") == "crash-1"]
    access = [line for line in lines if line["logger"] == "robodyn.access"]
    errors = [line for line in lines if line["level"] == "error"]
    assert len(access) == 1 and access[0]["status"] == 500
    assert errors and "RuntimeError: bug" in errors[0]["exc"]


def test_log_level_names():
    assert parse_level("WARNING") == logging.WARNING and parse_level("debug") == logging.DEBUG
    with pytest.raises(ValueError, match="debug, info, warning, error"):
        parse_level("verbose")


def test_an_unknown_log_level_stops_the_server_with_a_clear_message():
    env = {**os.environ, "ROBODYN_LOG_LEVEL": "loud"}
    proc = subprocess.run(
        [sys.executable, "-m", "service", "--port", "0"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2 and "ROBODYN_LOG_LEVEL" in proc.stderr


def test_real_server_writes_one_json_line_per_request(tmp_path):
    """`python -m service` at ROBODYN_LOG_LEVEL=info: every stderr line is JSON, one access
    line per request with our request id; at that level probe lines are left out."""
    from tests.servers import running_server

    log_path = tmp_path / "data" / "server.log"
    with (
        running_server(tmp_path / "data", catalog="ur5", log_level="info") as base,
        httpx.Client() as http,
    ):
        for i in range(3):
            r = http.post(
                f"{base}/v1/robots/ur5/gravity",
                json={"q": Q_UR5},
                headers={"X-Request-ID": f"e2e-{i}"},
            )
            assert r.status_code == 200 and r.headers["x-request-id"] == f"e2e-{i}"
        deadline = time.monotonic() + 10
        while "e2e-2" not in log_path.read_text() and time.monotonic() < deadline:
            time.sleep(0.05)
    lines = [json.loads(line) for line in log_path.read_text().splitlines()]
    access = [line for line in lines if line["logger"] == "robodyn.access"]
    assert [line["request_id"] for line in access] == ["e2e-0", "e2e-1", "e2e-2"]
    assert all(line["quantity"] == "gravity" and line["robot"] == "ur5" for line in access)
    assert not [line for line in access if line["route"] == "/health/ready"]  # polled above
    assert any(line["logger"] == "robodyn.registry" for line in lines)  # server's own lines


def test_the_fast_access_line_equals_the_logged_record(monkeypatch):
    """`write_fields` (used when our handler alone receives the access logger's records) writes
    the same JSON as logging a record with `extra={"fields": ...}`; with any other handler on
    the way (a test's capture, an operator's own), the middleware logs records instead."""
    fast, slow = io.StringIO(), io.StringIO()
    handler = JSONLineHandler(fast)
    handler.setFormatter(JSONFormatter())
    fields = {"request_id": "r1", "status": 200, "robot": "ur5", "compute_ms": 0.012}
    monkeypatch.setattr(time, "time", lambda: 1_700_000_000.25)
    handler.write_fields("info", "robodyn.access", "request", fields)
    record = logging.LogRecord("robodyn.access", logging.INFO, __file__, 1, "request", None, None)
    record.fields, record.created = fields, 1_700_000_000.25
    slow.write(handler.format(record) + "\n")
    assert fast.getvalue() == slow.getvalue()
    assert json.loads(fast.getvalue())["ts"] == "2023-11-14T22:13:20.250Z"

    root = logging.getLogger()
    access = logging.getLogger("robodyn.access")
    monkeypatch.setattr(root, "handlers", [handler])
    assert sole_json_handler(access) is handler
    monkeypatch.setattr(root, "handlers", [handler, logging.NullHandler()])
    assert sole_json_handler(access) is None
    monkeypatch.setattr(root, "handlers", [handler])
    monkeypatch.setattr(logging.getLogger("robodyn"), "handlers", [logging.NullHandler()])
    assert sole_json_handler(access) is None
