"""identify and its worker process, through the app: the fit is awaited on the event loop (a
large batch is computed meanwhile, not after it), a client that disconnects stops its fit at
once (its worker process is killed), and a worker killed from outside during a fit (the kernel's
OOM killer) is a 503 overloaded with Retry-After, not a 422 about the log."""

from __future__ import annotations

import asyncio
import os
import signal
import threading
import time
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.descendants import wait_ended
from tests.service.api.encoding.test_binary import BIN, encode_request
from tests.service.dynamics.identification_logs import synthetic_log

ROUTE = "/v1/robots/ur5/identify"
END_S = 30.0  # a killed worker process is gone well within this
RUNNING_S = 120.0  # a fit is running in the worker within this


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    registry = Registry(tmp_path_factory.mktemp("store"), ["ur5"])
    registry.load()
    return create_app(Settings(data_dir=registry.store.dir.parent, catalog="ur5"), registry)


@pytest.fixture(scope="module")
def client(app):
    with TestClient(app, raise_server_exceptions=False) as client:
        yield client


@pytest.fixture(scope="module")
def long_body(app) -> bytes:
    """A log whose fit takes seconds (a minute at 1 kHz), in the binary form."""
    log = synthetic_log(app.state.registry.get("ur5").model, seed=3, duration=60.0, rate=1000.0)
    return encode_request({"t": log.t, "q": log.q, "tau": log.tau}, {"store": False})


def _fitting_pid(app, timeout_s: float = RUNNING_S) -> int:
    """The pid of the worker process once a fit was sent to it."""
    deadline = time.monotonic() + timeout_s
    while True:
        worker = getattr(app.state, "identification", None)
        running = None if worker is None else worker._running
        if running is not None and running.sent and worker._proc is not None:
            return int(worker._proc.pid)
        assert time.monotonic() < deadline, "no fit started"
        time.sleep(0.02)


def _post_in_thread(client, body: bytes, out: dict[str, Any], key: str) -> threading.Thread:
    def post() -> None:
        out[key] = client.post(ROUTE, content=body, headers={"Content-Type": BIN})

    thread = threading.Thread(target=post)
    thread.start()
    return thread


def test_a_worker_killed_from_outside_is_a_503_with_retry_after(app, client, long_body):
    out: dict[str, Any] = {}
    thread = _post_in_thread(client, long_body, out, "identify")
    os.kill(_fitting_pid(app), signal.SIGKILL)  # as the kernel's OOM killer does
    thread.join(RUNNING_S)
    answer = out["identify"]
    assert answer.status_code == 503, answer.text
    assert answer.headers["retry-after"] and answer.json()["code"] == "overloaded"
    detail = answer.json()["detail"]
    assert "killed by signal 9 (SIGKILL)" in detail and "out of memory" in detail


def test_fits_wait_for_their_worker_without_holding_the_batches_slots(app, client, long_body):
    """Two fits in flight (one running, one waiting for the worker) leave every off-loop slot
    to large batches: a batch sent meanwhile is answered while both fits are still going."""
    out: dict[str, Any] = {}
    threads = [_post_in_thread(client, long_body, out, f"fit{i}") for i in range(2)]
    _fitting_pid(app)
    worker = app.state.identification
    deadline = time.monotonic() + RUNNING_S
    while len(worker._queue) < 1:  # the second fit waits for the worker
        assert time.monotonic() < deadline and not out, out
        time.sleep(0.02)
    # Off the event loop; in the binary form, so that it is answered in milliseconds (as JSON
    # its 2.4 MB were parsed in a child process started for it: 2.3 s, a good part of the
    # fits' time, which made the two fits end before the third was sent on a slow run).
    q = np.random.default_rng(0).uniform(-1, 1, (20_000, 6))
    batch = client.post(
        "/v1/robots/ur5/gravity", content=encode_request({"q": q}), headers={"Content-Type": BIN}
    )
    assert batch.status_code == 200, batch.text[:300]
    assert not out, "a fit ended before the batch was answered"
    third = client.post(ROUTE, content=long_body, headers={"Content-Type": BIN})
    assert third.status_code == 503 and third.json()["code"] == "overloaded", third.text
    assert third.headers["retry-after"] and "running and waiting" in third.json()["detail"]
    for thread in threads:
        thread.join(2 * RUNNING_S)
    assert [out[f"fit{i}"].status_code for i in range(2)] == [200, 200]


def test_a_client_that_disconnects_stops_its_fit_at_once(app, long_body):
    """The request's ASGI `receive` says `http.disconnect` once its fit runs: the worker
    process fitting it is killed (not left fitting for nobody), and a new one serves next."""
    sent: list[dict[str, Any]] = []

    async def scenario() -> int:
        fitting: list[int] = []
        messages = [{"type": "http.request", "body": long_body, "more_body": False}]

        async def receive() -> dict[str, Any]:
            if messages:
                return messages.pop()
            pid = await asyncio.to_thread(_fitting_pid, app)
            fitting.append(pid)
            return {"type": "http.disconnect"}

        async def send(message: dict[str, Any]) -> None:
            sent.append(message)

        scope = {
            "type": "http",
            "asgi": {"version": "3.0"},
            "http_version": "1.1",
            "method": "POST",
            "scheme": "http",
            "path": ROUTE,
            "raw_path": ROUTE.encode(),
            "root_path": "",
            "query_string": b"",
            "headers": [(b"content-type", BIN.encode()), (b"host", b"test")],
            "client": ("127.0.0.1", 1),
            "server": ("test", 80),
            "state": {},
        }
        await app(scope, receive, send)
        return fitting[0]

    pid = asyncio.run(scenario())
    assert not wait_ended({pid}, END_S), "the fit went on in its worker"
    assert sent[0]["status"] == 503  # the answer nobody reads
