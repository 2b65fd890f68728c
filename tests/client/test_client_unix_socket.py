"""Co-located clients: a real `python -m service` also serving on a Unix socket, its large
binary batches through shared-memory segments (service/segments, robodyn/shared_memory.py).

Answers over the socket equal in-process Pinocchio and the TCP answers; API keys and limits
apply as over TCP; the socket has its mode and is removed on shutdown with the segment
directory; no segment is left after errors, nor after a client killed mid-request."""

from __future__ import annotations

import asyncio
import gc
import os
import signal
import stat
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
import robodyn
from robodyn import AsyncClient, Client, PayloadTooLargeError, UnauthorizedError, shared_memory
from robodyn.errors import DimensionMismatchError, RobotNotFoundError

from service.segments.directory import held
from tests.client.helpers import RTOL, Reference
from tests.servers import running_server

KEY = "socket-test-key"
BODY_LIMIT = 4 * 1024 * 1024  # bytes: a 5 MB batch is over it, over TCP and the socket alike
WAIT_S = 20.0  # for the server to notice a killed client (its sweeper runs every 2 s)
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def sockets(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, Path]]:
    """A server with API keys on every route, also on a Unix socket: (TCP URL, socket)."""
    data = tmp_path_factory.mktemp("socket-server")
    sock = data / "robodyn.sock"
    with running_server(
        data,
        catalog="ur5,talos",
        api_keys=KEY,
        api_keys_scope="all",
        max_body_bytes=str(BODY_LIMIT),
        unix_socket=str(sock),
    ) as url:
        yield url, sock


def segments_of(sock: Path) -> Path:
    """The segment directory itself (the link beside the socket resolved)."""
    return Path(os.path.realpath(shared_memory.directory_of(str(sock))))


def leftovers(sock: Path) -> list[str]:
    """The files of the segment directory but the service's own answer files (`s-`, kept
    mapped by each server process for the next answers, removed at its shutdown)."""
    return sorted(n for n in os.listdir(segments_of(sock)) if not n.startswith("s-"))


def wait_until_empty(sock: Path) -> list[str]:
    deadline = time.monotonic() + WAIT_S
    while leftovers(sock) and time.monotonic() < deadline:
        time.sleep(0.1)
    return leftovers(sock)


@pytest.fixture
def shared_answers(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The names of the answers the client read from shared memory during a test."""
    names: list[str] = []
    original = shared_memory.Segment.answer

    def answer(self: shared_memory.Segment, name: str, status: int) -> Any:
        names.append(name)
        return original(self, name, status)

    monkeypatch.setattr(shared_memory.Segment, "answer", answer)
    return names


def test_the_socket_is_private_and_its_segments_are_in_memory(sockets):
    _, sock = sockets
    assert stat.S_ISSOCK(os.lstat(sock).st_mode)
    assert stat.S_IMODE(os.lstat(sock).st_mode) == 0o600
    directory = segments_of(sock)
    info = os.lstat(directory)
    assert stat.S_ISDIR(info.st_mode) and stat.S_IMODE(info.st_mode) == 0o700
    assert info.st_uid == os.geteuid()
    lines = Path("/proc/self/mounts").read_text().splitlines()
    mounts = {line.split()[1]: line.split()[2] for line in lines}
    holder = max((m for m in mounts if str(directory).startswith(m.rstrip("/") + "/")), key=len)
    assert mounts[holder] in ("tmpfs", "ramfs")


def test_batches_through_shared_memory_equal_in_process_pinocchio_and_tcp(
    sockets, reference: Reference, shared_answers: list[str]
):
    url, sock = sockets
    s = reference.states("talos", 600, seed=3)
    q, v, a = s["q"], s["v"], s["a"]
    with (
        Client(f"unix://{sock}", api_key=KEY, timeout=120) as local,
        Client(url, api_key=KEY, timeout=120) as remote,
    ):
        assert local.base_url == f"unix://{sock}"
        M = local.mass_matrix("talos", q)
        tau = local.inverse_dynamics("talos", q, v, a)
        C, Cv = local.coriolis("talos", q, v)
        assert len(shared_answers) == 3  # each answer came through shared memory
        np.testing.assert_allclose(M, reference.mass_matrix("talos", q), rtol=RTOL, atol=1e-10)
        np.testing.assert_allclose(
            tau, reference.inverse_dynamics("talos", q, v, a), rtol=RTOL, atol=1e-9
        )
        C_ref, Cv_ref = reference.coriolis("talos", q, v)
        np.testing.assert_allclose(C, C_ref, rtol=RTOL, atol=1e-10)
        np.testing.assert_allclose(Cv, Cv_ref, rtol=RTOL, atol=1e-9)
        # the same answers, bit for bit, as a TCP client's (which sends the body itself)
        assert np.array_equal(M, remote.mass_matrix("talos", q))
        assert np.array_equal(tau, remote.inverse_dynamics("talos", q, v, a))
        M[0, 0, 0] = 1.0  # the arrays are the caller's: writable
        # single states and small batches go through the socket itself, as JSON
        one = local.gravity("ur5", np.zeros(6))
        np.testing.assert_allclose(one, reference.gravity("ur5", np.zeros((1, 6)))[0], atol=1e-10)
    assert len(shared_answers) == 3
    # each answer is in an answer room of the client's (no copy), kept while it is alive
    assert [n[:2] for n in leftovers(sock)] == ["c-"] * 3
    del M, tau, C, Cv
    gc.collect()
    assert leftovers(sock) == []


def test_answers_kept_by_the_caller_stay_as_they_were(sockets, reference: Reference):
    """Each answer's memory is the caller's until its arrays are gone: later answers of the
    same size (through shared memory and over TCP) never write into one still held."""
    url, sock = sockets
    s = reference.states("talos", 600, seed=5)
    q, v, a = s["q"], s["v"], s["a"]
    with (
        Client(f"unix://{sock}", api_key=KEY, timeout=120) as local,
        Client(url, api_key=KEY, timeout=120, binary=True) as remote,
    ):
        for client in (local, remote):
            kept = [client.inverse_dynamics("talos", q, v, a * k) for k in range(4)]
            view = kept[1][5:9]
            for _ in range(3):  # answers dropped at once: their memory is reused
                client.inverse_dynamics("talos", q, v, -a)
            for k, tau in enumerate(kept):
                expected = reference.inverse_dynamics("talos", q, v, a * k)
                np.testing.assert_allclose(tau, expected, rtol=RTOL, atol=1e-9)
            del kept
            expected = reference.inverse_dynamics("talos", q, v, a)[5:9]
            np.testing.assert_allclose(view, expected, rtol=RTOL, atol=1e-9)


def test_a_non_finite_input_is_the_same_input_error_as_over_tcp(
    sockets, reference: Reference, shared_answers: list[str]
):
    """A large batch through shared memory is checked by the server; when it refuses it, the
    client raises its own InputError, word for word the one a TCP client raises before
    sending."""
    url, sock = sockets
    s = reference.states("talos", 600, seed=6)
    v = s["v"].copy()
    v[417, 3] = np.nan
    messages = []
    with (
        Client(f"unix://{sock}", api_key=KEY, timeout=120) as local,
        Client(url, api_key=KEY, timeout=120) as remote,
    ):
        for client in (local, remote):
            with pytest.raises(robodyn.InputError) as raised:
                client.inverse_dynamics("talos", s["q"], v, s["a"])
            messages.append(str(raised.value))
    assert messages[0] == messages[1] and "v[417, 3] is nan" in messages[0]
    assert shared_answers == []  # (refused: no answer in shared memory)
    assert leftovers(sock) == []


def test_async_client_and_stream_over_the_socket(sockets, reference: Reference, shared_answers):
    _, sock = sockets
    s = reference.states("talos", 400, seed=4)

    async def run() -> tuple[np.ndarray, np.ndarray]:
        async with AsyncClient(f"unix://{sock}", api_key=KEY, timeout=120) as client:
            a = await client.forward_dynamics("talos", s["q"], s["v"], s["tau"])
            async with client.stream("ur5") as stream:
                tau = await stream.inverse_dynamics(np.zeros(6), np.zeros(6), np.zeros(6))
            return a, tau

    a, tau = asyncio.run(run())
    assert len(shared_answers) == 1
    np.testing.assert_allclose(
        a, reference.forward_dynamics("talos", s["q"], s["v"], s["tau"]), rtol=1e-9, atol=1e-8
    )
    zeros = np.zeros((1, 6))
    np.testing.assert_allclose(
        tau, reference.inverse_dynamics("ur5", zeros, zeros, zeros)[0], atol=1e-10
    )
    with Client(f"unix://{sock}", api_key=KEY) as client, client.stream("ur5") as stream:
        g = stream.gravity(np.zeros(6))
    np.testing.assert_allclose(g, reference.gravity("ur5", zeros)[0], atol=1e-10)
    assert [n[:2] for n in leftovers(sock)] == ["c-"]  # the room of `a`, while `a` lives
    del a
    gc.collect()
    assert leftovers(sock) == []


def test_the_socket_refuses_requests_without_the_key(sockets, reference: Reference):
    _, sock = sockets
    s = reference.states("talos", 300)
    with Client(f"unix://{sock}") as client:
        with pytest.raises(UnauthorizedError):
            client.gravity("ur5", np.zeros(6))
        with pytest.raises(UnauthorizedError):  # a batch written into shared memory
            client.mass_matrix("talos", s["q"])
        with pytest.raises(UnauthorizedError):
            client.robots()
    with Client(f"unix://{sock}", api_key="wrong") as client, pytest.raises(UnauthorizedError):
        client.inverse_dynamics("talos", s["q"], s["v"], s["a"])
    assert leftovers(sock) == []


def test_errors_and_limits_are_those_of_tcp_and_leave_nothing(sockets, reference: Reference):
    url, sock = sockets
    s = reference.states("talos", 2000)
    large = np.concatenate([s["q"]] * 9)  # 18,000 × 39 numbers: 5.6 MB, over the 4 MiB limit
    for address in (f"unix://{sock}", url):
        with Client(address, api_key=KEY, timeout=120) as client:
            with pytest.raises(PayloadTooLargeError, match="ROBODYN_MAX_BODY_BYTES"):
                client.mass_matrix("talos", large)
            with pytest.raises(DimensionMismatchError, match="nq = 39"):
                client.mass_matrix("talos", s["q"][:, :30])
            with pytest.raises(RobotNotFoundError):
                client.mass_matrix("no-such-robot", s["q"])
    assert leftovers(sock) == []


def test_segments_are_refused_where_they_do_not_belong(sockets):
    url, sock = sockets
    headers = {
        "authorization": f"Bearer {KEY}",
        "content-type": "application/vnd.robodyn.safetensors",
        "robodyn-shared-body": "r-" + "0" * 32 + " 100",
    }
    path = "/v1/robots/ur5/gravity"
    tcp = httpx.post(url + path, headers=headers, timeout=10)
    assert tcp.status_code == 422 and "Unix socket" in tcp.json()["detail"]
    with httpx.Client(transport=httpx.HTTPTransport(uds=str(sock)), timeout=10) as local:
        missing = local.post("http://localhost" + path, headers=headers)
        assert missing.status_code == 422 and "does not exist" in missing.json()["detail"]
        for name in ("../robodyn.sock 100", "r-" + "0" * 31 + "/ 100", "R-" + "0" * 32 + " 1"):
            bad = local.post(
                "http://localhost" + path, headers={**headers, "robodyn-shared-body": name}
            )
            assert bad.status_code == 422 and "not a segment name" in bad.json()["detail"]
        unsized = local.post(
            "http://localhost" + path, headers={**headers, "robodyn-shared-body": "r-" + "0" * 32}
        )
        assert unsized.status_code == 422 and "length in bytes" in unsized.json()["detail"]
        huge = local.post(
            "http://localhost" + path,
            headers={**headers, "robodyn-shared-body": "r-" + "0" * 32 + f" {BODY_LIMIT + 1}"},
        )
        assert huge.status_code == 413 and huge.json()["code"] == "payload_too_large"
        elsewhere = local.get("http://localhost/v1/robots/ur5", headers=headers)
        assert elsewhere.status_code == 422 and "dynamics routes" in elsewhere.json()["detail"]
        assert local.get("http://localhost/health/ready").status_code == 200
    assert leftovers(sock) == []


KILLED_CLIENT = """
import sys, numpy as np
from robodyn import Client
q = np.load(sys.argv[2])
with Client("unix://" + sys.argv[1], api_key=sys.argv[3], timeout=600, retry=None) as client:
    while True:
        client.mass_matrix("talos", q)
"""


def test_nothing_is_left_after_a_client_is_killed_mid_request(
    sockets, reference: Reference, tmp_path: Path
):
    """A client sending batches in a loop is SIGKILLed while a segment of its is in the
    directory (its request being computed, or its answer not yet read)."""
    _, sock = sockets
    states = tmp_path / "q.npy"
    np.save(states, reference.states("talos", 4000)["q"])  # 1.2 MB in, 46 MB out
    env = {**os.environ, "PYTHONPATH": str(ROOT / "clients/python/src")}
    for delay in (0.0, 0.3, 0.6):  # killed at once, or with its request further along
        proc = subprocess.Popen(
            [sys.executable, "-c", KILLED_CLIENT, str(sock), str(states), KEY], env=env
        )
        try:
            deadline = time.monotonic() + 60
            while not any(n.startswith("r-") for n in leftovers(sock)):  # a request named
                assert proc.poll() is None and time.monotonic() < deadline
                time.sleep(0.01)
            time.sleep(delay)
        finally:
            proc.send_signal(signal.SIGKILL)
            proc.wait(10)
        left = wait_until_empty(sock)
        assert left == [], (delay, left, [held(segments_of(sock) / n) for n in left])
    with Client(f"unix://{sock}", api_key=KEY) as client:  # still serving
        assert client.ready()


LOCKED_SEGMENT = """
import sys, time
from robodyn import shared_memory
segment = shared_memory.SharedMemory(sys.argv[1]).segment([b"x" * 100_000])
print(segment.name, flush=True)
time.sleep(600)
"""


def test_a_segment_whose_client_died_before_sending_is_swept(sockets):
    _, sock = sockets
    env = {**os.environ, "PYTHONPATH": str(ROOT / "clients/python/src")}
    proc = subprocess.Popen(
        [sys.executable, "-c", LOCKED_SEGMENT, str(sock)],
        env=env,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        name = proc.stdout.readline().strip()
        time.sleep(3.0)  # more than a sweep: a live client's segment is kept
        assert name in leftovers(sock)  # (with its body file, c-...)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
        if proc.stdout is not None:
            proc.stdout.close()
    assert wait_until_empty(sock) == []


def test_the_socket_and_segments_are_removed_on_shutdown(tmp_path: Path, reference: Reference):
    """With two worker processes and mode 0660: both workers serve the socket; on SIGTERM
    the socket and the segment directory (and its link) are gone."""
    sock = tmp_path / "shutdown.sock"
    link = Path(shared_memory.directory_of(str(sock)))
    q = reference.states("talos", 300)["q"]
    with running_server(
        tmp_path / "data",
        catalog="talos",
        workers="2",
        unix_socket=str(sock),
        unix_socket_mode="0660",
    ):
        assert stat.S_IMODE(os.lstat(sock).st_mode) == 0o660
        directory = Path(os.path.realpath(link))
        with Client(f"unix://{sock}", timeout=120) as client:
            for _ in range(4):  # (connections spread over both workers)
                np.testing.assert_allclose(
                    client.mass_matrix("talos", q), reference.mass_matrix("talos", q), atol=1e-10
                )
    assert not os.path.lexists(sock)
    assert not os.path.lexists(link)
    assert not os.path.lexists(directory)
