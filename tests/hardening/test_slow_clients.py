"""Slow and stalled clients against a real `python -m service`: connections that send part of
a request line, of the headers or of a body and then nothing are closed within their timeout
while normal requests keep being answered; past the connection cap, stalled connections are
evicted first and, when every connection is busy, a new one gets a 503 `overloaded`; a client
that never reads its answer is dropped. All on loopback, every loop bounded."""

from __future__ import annotations

import contextlib
import re
import socket
import threading
import time
from collections.abc import Iterator

import httpx
import numpy as np
import pytest

from service.server.protocol import LINGER_S
from tests.hardening.raw_http import GOOD_BODY, connect, good_request, read_answer, request
from tests.servers import running_server

TIMEOUT_S = 1.5
STALLED = 200


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    with running_server(
        tmp_path_factory.mktemp("slow"),
        catalog="ur5",
        header_timeout_s=str(TIMEOUT_S),
        body_timeout_s=str(TIMEOUT_S),
        send_timeout_s="2",
        max_connections="400",
    ) as url:
        yield url


def _partial(kind: int) -> bytes:
    full = request("POST", "/v1/robots/ur5/gravity", b'{"q": [0, 0, 0, 0, 0, 0]}')
    head_end = full.index(b"\r\n\r\n") + 4
    return [full[:10], full[: head_end - 10], full[: head_end + 5]][kind]  # line, headers, body


def _wait_closed(socks: list[socket.socket], seconds: float) -> list[float | None]:
    """When (`time.monotonic()`) each socket saw the server close it, polling all at once for
    at most `seconds`; None for those still open."""
    closed: list[float | None] = [None] * len(socks)
    started = time.monotonic()
    for sock in socks:
        sock.setblocking(False)
    while time.monotonic() - started < seconds and None in closed:
        for i, sock in enumerate(socks):
            if closed[i] is not None:
                continue
            try:
                if not sock.recv(65536):
                    closed[i] = time.monotonic()
            except BlockingIOError:
                pass
            except OSError:
                closed[i] = time.monotonic()
        time.sleep(0.05)
    return closed


def _metric(base: str, reason: str) -> float:
    text = httpx.get(base + "/metrics").text
    found = re.search(rf'robodyn_connections_closed_total\{{reason="{reason}"\}} (\S+)', text)
    return float(found.group(1)) if found else 0.0


def _stall_beside_requests(base: str) -> tuple[list[float], list[float | None], list, list]:
    """STALLED connections each sending part of a request line, of the headers or of a body
    (in turn), and normal requests on another connection until the stalled ones are closed
    (at most TIMEOUT_S + 8 s): when each stalled connection was opened and closed
    (`time.monotonic()`), the normal requests' statuses and latencies (s)."""
    opened, socks = [], []
    for i in range(STALLED):
        opened.append(time.monotonic())
        sock = connect(base)
        sock.sendall(_partial(i % 3))
        socks.append(sock)
    statuses: list[int] = []
    latencies: list[float] = []
    stop = threading.Event()

    def normal_requests() -> None:
        with httpx.Client(base_url=base, timeout=5) as client:
            while not stop.is_set() and len(latencies) < 10_000:
                t = time.perf_counter()
                r = client.post("/v1/robots/ur5/gravity", json={"q": [0.1] * 6})
                latencies.append(time.perf_counter() - t)
                statuses.append(r.status_code)

    worker = threading.Thread(target=normal_requests)
    worker.start()
    try:
        closed = _wait_closed(socks, TIMEOUT_S + 8)
    finally:
        stop.set()
        worker.join(10)
        for sock in socks:
            sock.close()
    return opened, closed, statuses, latencies


def test_stalled_requests_are_closed_while_others_are_answered(base: str) -> None:
    """Every stalled connection is closed, by its timeout: not before TIMEOUT_S from its
    connection (the server starts timing it then: a rule, not a measurement), and within
    a few seconds after; meanwhile normal requests are answered."""
    before = {r: _metric(base, r) for r in ("header_timeout", "body_timeout")}
    opened, closed, statuses, _ = _stall_beside_requests(base)
    assert closed.count(None) == 0, f"{closed.count(None)} stalled connections left open"
    lived = [c - o for o, c in zip(opened, closed, strict=True) if c is not None]
    assert min(lived) >= TIMEOUT_S - 1e-6, min(lived)  # closed by the timeout, not at once
    assert max(lived) < TIMEOUT_S + 8, max(lived)
    assert len(statuses) >= 3 and set(statuses) == {200}, statuses[-5:]
    after = {r: _metric(base, r) for r in ("header_timeout", "body_timeout")}
    assert after["header_timeout"] - before["header_timeout"] >= 2 * STALLED // 3 - 1
    assert after["body_timeout"] - before["body_timeout"] >= STALLED // 3 - 1


@pytest.mark.slow  # a latency bound: with the other latency probes in the slow suite
def test_stalled_requests_do_not_slow_the_others(base: str) -> None:
    """While STALLED connections wait for their timeout, normal requests keep their latency:
    p99 under 0.25 s."""
    _, _, statuses, latencies = _stall_beside_requests(base)
    assert set(statuses) == {200}
    assert len(latencies) > 20 and np.percentile(latencies, 99) < 0.25, len(latencies)


def test_a_slowly_trickled_head_is_closed_at_the_deadline(base: str) -> None:
    """One byte every 0.3 s never completes the headers: the deadline counts from the first
    byte, not from the last."""
    partial = _partial(1)
    with connect(base) as sock:
        started = time.monotonic()
        closed_at = None
        for byte in partial:
            try:
                sock.sendall(bytes([byte]))
            except OSError:
                closed_at = time.monotonic() - started
                break
            time.sleep(0.3)
            if time.monotonic() - started > TIMEOUT_S + 3:
                break
        if closed_at is None:
            sock.settimeout(3)
            with contextlib.suppress(ConnectionResetError):
                assert sock.recv(100) == b""
            closed_at = time.monotonic() - started
    assert closed_at < TIMEOUT_S + 3


def test_slow_but_steady_clients_are_not_cut(base: str) -> None:
    """A head sent in two parts within its deadline, then a body in five parts with pauses
    of a third of the timeout (2.5 s in all, longer than the timeout: the pauses count, not
    the whole), is read and answered."""
    raw = good_request()
    head_end = raw.index(b"\r\n\r\n") + 4
    middle = head_end // 2
    head, body = [raw[:middle], raw[middle:head_end]], raw[head_end:]
    parts = head + [body[i : i + 5] for i in range(0, len(body), 5)]
    assert len(parts) == 7
    with connect(base) as sock:
        for i, part in enumerate(parts):
            if i:
                time.sleep(TIMEOUT_S / 3)
            sock.sendall(part)
        assert read_answer(sock).status == 200


def test_a_client_that_does_not_read_its_answer_is_dropped(base: str) -> None:
    q = b"[" + b",".join([b"[0.1,0.2,0.3,0.4,0.5,0.6]"] * 4000) + b"]"
    with connect(base) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        for _ in range(20):  # ~20 answers of 2 MB each, none read
            sock.sendall(request("POST", "/v1/robots/ur5/mass-matrix", b'{"q": ' + q + b"}"))
        time.sleep(2 + 3)  # the send timeout is 2 s
        sock.settimeout(5)  # a TimeoutError below: the server did not drop the connection
        received = 0
        with contextlib.suppress(ConnectionResetError):
            while chunk := sock.recv(1 << 20):
                received += len(chunk)
        assert received < 20 * 2_000_000  # dropped with answers unsent


@pytest.fixture
def capped(tmp_path) -> Iterator[str]:
    with running_server(
        tmp_path, catalog="ur5", max_connections="20", header_timeout_s="30", body_timeout_s="30"
    ) as url:
        yield url


def test_past_the_cap_stalled_connections_make_room(capped: str) -> None:
    stalled = []
    for _ in range(60):  # three times the cap, all half-sent heads
        sock = connect(capped)
        sock.sendall(_partial(1))
        stalled.append(sock)
    time.sleep(0.3)
    with httpx.Client(base_url=capped, timeout=5) as client:
        for _ in range(10):
            assert client.post("/v1/robots/ur5/gravity", json={"q": [0] * 6}).status_code == 200
    closed = _wait_closed(stalled, 1.0)
    assert sum(c is not None for c in closed) >= 40  # the oldest were evicted
    for sock in stalled:
        sock.close()


def test_when_every_connection_is_busy_a_new_one_gets_503(capped: str) -> None:
    busy = []
    full = request("POST", "/v1/robots/ur5/gravity", GOOD_BODY, headers=("expect: 100-continue",))
    for _ in range(20):  # heads complete, bodies pending: requests in progress
        sock = connect(capped)
        sock.sendall(full[: full.index(b"\r\n\r\n") + 4 + 5])
        busy.append(sock)
    for sock in busy:  # the server began reading the body: the request is in progress
        assert sock.recv(100).startswith(b"HTTP/1.1 100 Continue")
    try:
        with connect(capped) as sock:
            sock.sendall(good_request())
            answer = read_answer(sock)
            assert answer.status == 503, answer
            assert answer.json()["code"] == "overloaded" and answer.headers["retry-after"]
            assert answer.closes
            sock.settimeout(LINGER_S + 2)
            with contextlib.suppress(ConnectionResetError):
                assert sock.recv(100) == b""
    finally:
        for sock in busy:
            sock.close()
    # Once the server has seen them go (a few milliseconds; longer on a loaded machine), a
    # new connection is answered.
    deadline = time.monotonic() + 10
    while (
        status := httpx.post(capped + "/v1/robots/ur5/gravity", json={"q": [0] * 6}).status_code
    ) == 503 and time.monotonic() < deadline:
        time.sleep(0.1)
    assert status == 200


def test_an_idle_websocket_stream_is_not_a_stalled_request(base: str) -> None:
    """The read timeouts guard HTTP requests; an upgraded stream idles as long as it likes."""
    import robodyn

    q = np.zeros(6)
    with robodyn.Client(base) as client, client.stream("ur5") as stream:
        first = stream.inverse_dynamics(q, q, q)
        time.sleep(TIMEOUT_S * 2 + 0.5)
        np.testing.assert_array_equal(stream.inverse_dynamics(q, q, q), first)


def test_the_cap_stays_below_the_descriptor_limit(monkeypatch) -> None:
    import resource

    from service.server import protocol

    monkeypatch.setattr(resource, "getrlimit", lambda which: (200, 4096))
    protocol.connection_limits.cache_clear()
    try:
        assert protocol.connection_limits().max_connections == 200 - 64
        monkeypatch.setenv("ROBODYN_MAX_CONNECTIONS", "50")
        protocol.connection_limits.cache_clear()
        assert protocol.connection_limits().max_connections == 50
    finally:
        protocol.connection_limits.cache_clear()
