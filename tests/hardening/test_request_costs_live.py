"""The cost reproductions against a real server, with `/health/live` probed while each runs
(p99 < 0.25 s): a contact-heavy simulation and a 100,000-state contact batch are refused at
once; an admitted long computation stops at the request deadline, and when its client
disconnects; twelve clients not reading large answers hold at most
ROBODYN_MAX_ANSWER_BYTES_IN_FLIGHT, the others are answered 503 at once."""

from __future__ import annotations

import re
import select
import socket
import time
from collections.abc import Iterator
from urllib.parse import urlparse

import httpx
import numpy as np
import orjson
import pinocchio as pin
import pytest

from service.registry.catalog import load_catalog
from tests.hardening.health_probe import health_latencies_during
from tests.servers import running_server
from tests.service.api.encoding.test_binary import BIN, encode_request
from tests.service.dynamics.contacts.test_quantities import contacts_of

pytestmark = pytest.mark.slow

SOLO_Q = [0, 0, 0.235, 0, 0, 0, 1, 0.1, 0.8, -1.6, -0.1, 0.8, -1.6, 0.1, -0.8, 1.6, -0.1, -0.8, 1.6]
IN_FLIGHT = 300_000_000  # one 7,000-state Talos mass-matrix answer (~250 MB estimated)
DEADLINE_S = 2.0
REPEAT = 4  # a refusal takes milliseconds: repeated, so that p99 is not one probe's worst


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    with running_server(
        tmp_path_factory.mktemp("costs"), catalog="talos,solo12", request_deadline_s=str(DEADLINE_S)
    ) as url:
        yield url


@pytest.fixture(scope="module")
def answers_base(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The default deadline (a loaded machine may take seconds for the batch), a small
    budget of answer bytes in flight."""
    with running_server(
        tmp_path_factory.mktemp("answers"),
        catalog="talos",
        max_answer_bytes_in_flight=str(IN_FLIGHT),
    ) as url:
        yield url


@pytest.fixture(scope="module")
def robots() -> dict:
    loaded, failures = load_catalog(["talos", "solo12"])
    assert not failures
    return loaded


def _six_d(robot, count: int) -> list[dict[str, str]]:
    names = [
        f.name for f in robot.model.frames if f.type == pin.FrameType.BODY and f.parentJoint > 1
    ]
    return [{"frame": names[i % len(names)], "type": "6d"} for i in range(count)]


def _assert_live(latencies: list[float]) -> None:
    assert len(latencies) > 10
    assert np.percentile(latencies, 99) < 0.25, sorted(latencies)[-5:]


def test_a_contact_heavy_simulation_is_refused_at_once(base, robots) -> None:
    talos = robots["talos"]
    body = {
        "q": talos.default_configuration.tolist(),
        "v": [0.0] * talos.nv,
        "dt": 1e-3,
        "steps": 100_000,
        "integrator": "rk4",
        "contacts": _six_d(talos, 64),
        "damping": 0.1,
    }
    started = time.perf_counter()
    answers, latencies = health_latencies_during(
        base,
        lambda: [  # a few, for enough probes
            httpx.post(base + "/v1/robots/talos/simulate", json=body, timeout=60)
            for _ in range(REPEAT)
        ],
    )
    for r in answers:
        assert r.status_code == 422 and "ROBODYN_MAX_WORK" in r.json()["detail"]
        assert r.json()["largest_steps"] >= 0
    assert time.perf_counter() - started < 5 * REPEAT
    _assert_live(latencies)


def _solo_batch(n: int, contacts: list, **options: float) -> bytes:
    q = np.repeat(np.array(SOLO_Q, dtype=float)[None], n, 0)
    return encode_request(
        {"q": q, "v": np.zeros((n, 18)), "tau": np.zeros((n, 18))},
        {"contacts": contacts, **options},
    )


def test_a_100000_state_contact_batch_is_refused_at_once(base, robots) -> None:
    """100,000 states with 16 damped 6d contacts (minutes of computing; the answer, 91 MB in
    the binary form, is within the answer budget): refused by its work at once."""
    body = _solo_batch(100_000, _six_d(robots["solo12"], 16), damping=0.1)
    answers, latencies = health_latencies_during(
        base,
        lambda: [
            httpx.post(
                base + "/v1/robots/solo12/contact-dynamics",
                content=body,
                headers={"content-type": BIN, "accept": BIN},
                timeout=60,
            )
            for _ in range(REPEAT)
        ],
    )
    for r in answers:
        assert r.status_code == 422, r.text[:300]
        assert "ROBODYN_MAX_WORK" in r.json()["detail"] and r.json()["largest_batch"] < 100_000
    _assert_live(latencies)


# Admitted (under ROBODYN_MAX_WORK), and about 8 s of computing on one core.
LONG_ROLLOUT = {
    "q": SOLO_Q,
    "v": [0.0] * 18,
    "dt": 1e-4,
    "steps": 40_000,
    "integrator": "rk4",
    "contacts": contacts_of("solo12"),
}


def test_an_admitted_long_rollout_stops_at_the_deadline(base) -> None:
    def post() -> tuple[httpx.Response, float]:
        started = time.perf_counter()
        r = httpx.post(base + "/v1/robots/solo12/simulate", json=LONG_ROLLOUT, timeout=60)
        return r, time.perf_counter() - started

    (r, elapsed), latencies = health_latencies_during(base, post)
    assert r.status_code == 504 and r.json()["code"] == "deadline_exceeded", r.text[:300]
    assert "ROBODYN_REQUEST_DEADLINE_S" in r.json()["detail"]
    assert elapsed < DEADLINE_S + 2
    _assert_live(latencies)


def _stopped(base: str, reason: str) -> float:
    text = httpx.get(base + "/metrics", timeout=10).text
    found = re.search(rf'robodyn_computations_stopped_total\{{reason="{reason}"\}} (\S+)', text)
    return float(found.group(1)) if found else 0.0


def _raw_request(base: str, path: str, body: bytes, content_type: str) -> socket.socket:
    url = urlparse(base)
    sock = socket.create_connection((url.hostname, url.port))
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.sendall(
        f"POST {path} HTTP/1.1\r\nHost: test\r\nContent-Type: {content_type}\r\n"
        f"Content-Length: {len(body)}\r\n\r\n".encode()
        + body
    )
    return sock


def test_a_disconnect_stops_the_computation(base) -> None:
    body = orjson.dumps(LONG_ROLLOUT)
    before = _stopped(base, "disconnect")

    def go_away() -> float:
        sock = _raw_request(base, "/v1/robots/solo12/simulate", body, "application/json")
        time.sleep(0.5)
        sock.close()
        gone = time.perf_counter()
        while _stopped(base, "disconnect") == before and time.perf_counter() - gone < 10:
            time.sleep(0.05)
        return time.perf_counter() - gone

    waited, latencies = health_latencies_during(base, go_away)
    assert _stopped(base, "disconnect") == before + 1
    assert waited < 2.0
    _assert_live(latencies)


def test_unread_large_answers_are_bounded_in_total(answers_base, robots) -> None:
    """Twelve clients ask for 7,000 Talos mass matrices (~200 MB of JSON each) and read
    nothing: at most one answer is held (the limit is 300 MB), the others are 503 at once."""
    base, talos = answers_base, robots["talos"]
    body = orjson.dumps(
        {"q": np.repeat(talos.default_configuration[None], 7_000, 0)},
        option=orjson.OPT_SERIALIZE_NUMPY,
    )

    def unread() -> list[bytes]:
        socks = [
            _raw_request(base, "/v1/robots/talos/mass-matrix", body, "application/json")
            for _ in range(12)
        ]
        heads = []
        try:
            for sock in socks:
                ready, _, _ = select.select([sock], [], [], 120)
                assert ready, "no answer within 120 s"
                heads.append(sock.recv(2048))
        finally:
            for sock in socks:
                sock.close()
        return heads

    heads, latencies = health_latencies_during(base, unread)
    held = [h for h in heads if h.startswith(b"HTTP/1.1 200")]
    refused = [h for h in heads if h.startswith(b"HTTP/1.1 503")]
    assert 1 <= len(held) <= 2 and len(held) + len(refused) == 12, heads
    assert all(
        b"ROBODYN_MAX_ANSWER_BYTES_IN_FLIGHT" in h or b"retry-after" in h.lower() for h in refused
    )
    _assert_live(latencies)
    deadline = time.monotonic() + 30  # the closed connections give their bytes back
    while time.monotonic() < deadline:
        r = httpx.post(
            base + "/v1/robots/talos/mass-matrix",
            content=body,
            timeout=120,
            headers={"content-type": "application/json"},
        )
        if r.status_code == 200:
            break
        time.sleep(0.5)
    assert r.status_code == 200
