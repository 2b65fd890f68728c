"""Graceful shutdown: SIGTERM lets in-flight requests (an upload being built, a large batch)
finish with their full answers, refuses new connections, and the process exits cleanly."""

from __future__ import annotations

import json
import signal
import threading
import time

import httpx
import numpy as np
import pytest

from tests.hardening.corpus import chain

pytestmark = pytest.mark.slow


def test_sigterm_lets_in_flight_requests_finish(server_factory, tmp_path):
    server = server_factory(catalog="ur5").start()
    results: dict[str, httpx.Response] = {}

    def upload() -> None:  # nv = 128 (the cap): about a second to build and check
        results["upload"] = httpx.post(
            f"{server.base}/v1/robots", json={"urdf": chain(128, flat=True)}, timeout=60
        )

    # the body is made before the clock starts: encoding it takes longer than the wait below
    q = np.random.default_rng(1).uniform(-1, 1, (80_000, 6))  # about a second in flight
    body = json.dumps({"q": q.tolist()}).encode()

    def batch() -> None:
        results["batch"] = httpx.post(
            f"{server.base}/v1/robots/ur5/mass-matrix",
            content=body,
            headers={"content-type": "application/json"},
            timeout=60,
        )

    threads = [threading.Thread(target=upload), threading.Thread(target=batch)]
    for t in threads:
        t.start()
    time.sleep(0.4)  # both requests are in flight
    assert not results, "requests finished too early to test shutdown"
    server.proc.send_signal(signal.SIGTERM)
    time.sleep(0.3)
    with pytest.raises(httpx.TransportError):  # no new connections once shutting down
        httpx.get(f"{server.base}/health/live", timeout=2)
    for t in threads:
        t.join(60)
    # uvicorn re-raises the captured SIGTERM once it has shut down gracefully
    assert server.proc.wait(timeout=60) in (0, -signal.SIGTERM)
    assert "Traceback" not in server.log_text()
    assert results["upload"].status_code == 201, results["upload"].text
    robot_id = results["upload"].json()["id"]
    assert results["upload"].json()["nv"] == 128
    assert results["batch"].status_code == 200
    assert np.asarray(results["batch"].json()["mass_matrix"]).shape == (80_000, 6, 6)
    # the acknowledged upload is durable: a new server serves it
    again = server_factory(catalog="ur5").start()
    assert httpx.get(f"{again.base}/v1/robots/{robot_id}").status_code == 200
