"""The reproductions of the helper processes' review, against a real `python -m service` on a
busy machine, each with /health/live answering throughout (99 % of the probes within 0.25 s,
every one within `HEALTH_MAX_S`: on this 2-core machine, at a load of 10-11 from other work, the
slowest single probe of these runs took 0.5-1.0 s, while an idle server's took up to 0.3 s):

- two identifications in flight (one fitting, one waiting for the worker) leave a retiming its
  off-loop slot: it is answered while both are still going, and a third identification is
  refused at once (503 overloaded, Retry-After);
- identifications abandoned by their clients stop fitting at once (the worker process is killed
  and replaced): the next small identification does not wait behind them;
- a derivation of the equations too costly for its time limit holds its own slot, not an upload
  builder's (an upload meanwhile is built), and a robot with the same numbers under another id
  is refused at once with the same 422;
- a stopped JSON helper (SIGSTOP) holds a large body no longer than the helper's time (it is
  killed, the body parsed in process) and a retiming meanwhile is answered.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import threading
import time
from typing import Any

import httpx
import numpy as np
import orjson
import pytest

from service.api.json_bodies import HELPER_TIMEOUT_S
from service.registry.catalog import load_catalog
from tests.descendants import descendants, wait_ended
from tests.hardening.health_probe import health_latencies_during
from tests.helpers import planar_arm_urdf, skewed_arm_urdf
from tests.service.api.encoding.test_binary import BIN, encode_request
from tests.service.dynamics.identification_logs import synthetic_log

pytestmark = pytest.mark.slow

HEALTH_P99_S = 0.25  # /health/live: 99 % of the probes (every 5 ms) answered within this
HEALTH_MAX_S = 0.5  # and every one (on a machine without other work: at a load of 10, 0.5-1.0 s)
RETIME_S = 10.0  # a retiming alone takes about 0.7 s
SMALL_FIT_S = 30.0  # a small identification, a worker start (about 6 s) included
END_S = 30.0  # a killed process is gone within this
WAYPOINTS = np.random.default_rng(0).uniform(-2.0, 2.0, (40, 6)).tolist()


@pytest.fixture(scope="module")
def ur5_model():
    return load_catalog(["ur5"])[0]["ur5"].model


def _identify_body(model, duration: float, rate: float, seed: int) -> bytes:
    log = synthetic_log(model, seed=seed, duration=duration, rate=rate, noise=0.05)
    return encode_request({"t": log.t, "q": log.q, "tau": log.tau}, {"store": False})


def _post_in_thread(url: str, body: bytes, out: dict[str, Any], key: str, **kw) -> threading.Thread:
    def post() -> None:
        try:
            out[key] = httpx.post(url, content=body, headers={"content-type": BIN}, **kw)
        except httpx.HTTPError as exc:
            out[key] = exc

    thread = threading.Thread(target=post)
    thread.start()
    return thread


def _spawned(pid: int) -> set[int]:
    """The spawned helpers below the server `pid` (identification worker, JSON helper)."""
    return {child for child, cmd in descendants(pid).items() if "spawn_main" in cmd}


def _assert_live(latencies: list[float]) -> None:
    assert len(latencies) > 20, latencies
    assert np.percentile(latencies, 99) < HEALTH_P99_S, sorted(latencies)[-5:]
    assert max(latencies) < HEALTH_MAX_S, sorted(latencies)[-5:]


def _retime(base: str) -> tuple[httpx.Response, float]:
    started = time.monotonic()
    answer = httpx.post(f"{base}/v1/robots/ur5/retime", json={"waypoints": WAYPOINTS}, timeout=300)
    return answer, time.monotonic() - started


def test_fits_in_flight_leave_a_retiming_its_slot(server_factory, ur5_model):
    server = server_factory(catalog="ur5").start()
    long_fit = _identify_body(ur5_model, 120.0, 1000.0, seed=4)  # seconds of fitting each
    url = f"{server.base}/v1/robots/ur5/identify"
    out: dict[str, Any] = {}
    fits = [_post_in_thread(url, long_fit, out, f"fit{i}", timeout=600) for i in range(2)]
    time.sleep(3.0)  # both read and queued: one starting or fitting, one waiting
    assert not out, out

    def work() -> tuple[httpx.Response, float, httpx.Response]:
        retimed, seconds = _retime(server.base)
        in_flight = not out
        third = httpx.post(url, content=long_fit, headers={"content-type": BIN}, timeout=60)
        assert in_flight, "an identification ended before the retiming was answered"
        return retimed, seconds, third

    (retimed, seconds, third), latencies = health_latencies_during(server.base, work)
    for fit in fits:
        fit.join(600)
    assert retimed.status_code == 200, retimed.text[:300]
    assert seconds < RETIME_S, seconds
    assert third.status_code == 503 and third.json()["code"] == "overloaded", third.text
    assert third.headers["retry-after"]
    assert [out[f"fit{i}"].status_code for i in range(2)] == [200, 200], out
    _assert_live(latencies)


def test_abandoned_fits_stop_at_once(server_factory, ur5_model):
    server = server_factory(catalog="ur5").start()
    longest = _identify_body(ur5_model, 200.0, 1000.0, seed=5)  # 200,000 samples: the most
    small = _identify_body(ur5_model, 6.0, 50.0, seed=6)
    url = f"{server.base}/v1/robots/ur5/identify"
    warm = httpx.post(url, content=small, headers={"content-type": BIN}, timeout=300)
    assert warm.status_code == 200, warm.text[:300]  # the worker runs
    (worker,) = _spawned(server.proc.pid)

    def work() -> tuple[httpx.Response, float]:
        for _ in range(2):  # the client gives up after 4 s: it closes the connection
            with pytest.raises(httpx.ReadTimeout):
                httpx.post(url, content=longest, headers={"content-type": BIN}, timeout=4.0)
        started = time.monotonic()
        answer = httpx.post(url, content=small, headers={"content-type": BIN}, timeout=300)
        return answer, time.monotonic() - started

    (answer, seconds), latencies = health_latencies_during(server.base, work)
    assert not wait_ended({worker}, END_S), "the abandoned fit went on in its worker"
    assert answer.status_code == 200, answer.text[:300]
    assert seconds < SMALL_FIT_S, seconds
    _assert_live(latencies)


def test_a_costly_derivation_holds_its_own_slot_and_is_remembered(server_factory):
    server = server_factory(
        catalog="ur5",
        env={"ROBODYN_EQUATIONS_TIMEOUT_S": "1", "ROBODYN_MAX_CONCURRENT_BUILDS": "1"},
    ).start()
    costly = skewed_arm_urdf(6)  # seconds of CPU: past a 1 s limit
    renamed = re.sub(r'\b(name|link)="', r'\1="other_', costly)  # the same numbers
    with httpx.Client(base_url=server.base, timeout=300) as client:
        first = client.post("/v1/robots", json={"urdf": costly}).json()["id"]
        again = client.post("/v1/robots", json={"urdf": renamed}).json()["id"]
        assert first != again

        def work() -> tuple[httpx.Response, httpx.Response, httpx.Response, float]:
            out: dict[str, Any] = {}
            derive = threading.Thread(
                target=lambda: out.update(first=client.get(f"/v1/robots/{first}/equations"))
            )
            derive.start()
            time.sleep(1.0)  # deriving
            upload = client.post("/v1/robots", json={"urdf": planar_arm_urdf(0.9, 0.6, 1.2, 0.8)})
            derive.join(300)
            refused = out["first"]
            for _ in range(4):  # the machine starved it (503, not remembered): once more
                if refused.status_code != 503:
                    break
                refused = client.get(f"/v1/robots/{first}/equations")
            started = time.monotonic()
            remembered = client.get(f"/v1/robots/{again}/equations")
            return upload, refused, remembered, time.monotonic() - started

        (upload, refused, remembered, seconds), latencies = health_latencies_during(
            server.base, work
        )
    assert upload.status_code == 201, upload.text[:300]
    assert refused.status_code == 422, refused.text
    assert "time limit of 1 s" in refused.json()["detail"]
    assert remembered.status_code == 422 and remembered.json() == refused.json()
    assert seconds < 2.0, seconds  # at once: no derivation
    _assert_live(latencies)


def test_a_stopped_json_helper_holds_no_request(server_factory):
    server = server_factory(catalog="ur5").start()
    t = np.linspace(0.0, 20.0, 30_000)
    q = 0.4 * np.sin(t[:, None] * np.linspace(0.3, 1.8, 6)[None, :])
    large = orjson.dumps({"t": t.tolist(), "q": q.tolist()})
    check = f"{server.base}/v1/robots/ur5/trajectory-check"
    json_type = {"content-type": "application/json"}
    first = httpx.post(check, content=large, headers=json_type, timeout=300)
    assert first.status_code == 200, first.text[:300]
    (helper,) = _spawned(server.proc.pid)
    os.kill(helper, signal.SIGSTOP)
    try:

        def work() -> tuple[httpx.Response, float, httpx.Response, float]:
            out: dict[str, Any] = {}

            def post() -> None:
                started = time.monotonic()
                out["large"] = httpx.post(check, content=large, headers=json_type, timeout=300)
                out["seconds"] = time.monotonic() - started

            thread = threading.Thread(target=post)
            thread.start()
            time.sleep(0.5)  # waiting for the stopped helper
            retimed, retime_s = _retime(server.base)
            thread.join(300)
            return out["large"], out["seconds"], retimed, retime_s

        (answer, seconds, retimed, retime_s), latencies = health_latencies_during(server.base, work)
        assert not wait_ended({helper}, END_S), "the stopped helper is still there"
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(helper, signal.SIGKILL)
    assert answer.status_code == 200 and answer.json() == first.json()
    assert seconds < HELPER_TIMEOUT_S + 20.0, seconds
    assert retimed.status_code == 200 and retime_s < RETIME_S, (retimed.text[:300], retime_s)
    _assert_live(latencies)
    again = httpx.post(check, content=large, headers=json_type, timeout=300)
    assert again.status_code == 200 and len(_spawned(server.proc.pid)) == 1  # a new helper
