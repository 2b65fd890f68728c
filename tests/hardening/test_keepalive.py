"""Error answers on kept-alive connections, against a real `python -m service`: after any error
the connection either stays usable (the next request on the same socket is answered) or the
answer says `Connection: close` and the server then closes the socket cleanly (the client reads
the whole answer, never a reset or an empty reply)."""

from __future__ import annotations

import asyncio
import socket
import threading
import time
from collections.abc import Iterator

import httpx
import pytest
import uvicorn

from service.main import create_app
from service.server.protocol import LINGER_S, HardenedHttpToolsProtocol
from service.settings import Settings
from tests.hardening.raw_http import (
    closed_within,
    connect,
    good_request,
    read_answer,
    request,
)
from tests.servers import running_server

MAX_BODY = 65536


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    with running_server(
        tmp_path_factory.mktemp("keepalive"),
        catalog="ur5",
        max_body_bytes=str(MAX_BODY),
        max_answer_bytes="100000",
    ) as url:
        yield url


def _assert_usable_or_closed(sock: socket.socket, answer_closes: bool, base: str) -> None:
    if answer_closes:
        assert closed_within(sock, LINGER_S + 3) is not None, "said close, did not close"
        fresh = connect(base)
        fresh.sendall(good_request())
        assert read_answer(fresh).status == 200
        fresh.close()
    else:
        sock.sendall(good_request())
        answer = read_answer(sock)
        assert answer.status == 200, answer.body
        assert len(answer.json()["gravity"]) == 6


KEPT_ALIVE = {  # errors answered after the whole request was read: the connection stays
    "validation_error": (request("POST", "/v1/robots/ur5/gravity", b'{"q": "x"}'), 422),
    "malformed JSON": (request("POST", "/v1/robots/ur5/gravity", b'{"q": [0,'), 422),
    "dimension_mismatch": (request("POST", "/v1/robots/ur5/gravity", b'{"q": [0, 0]}'), 422),
    "unknown robot": (request("POST", "/v1/robots/nope/gravity", b'{"q": [0]}'), 404),
    "unknown route": (request("GET", "/nope"), 404),
    "method": (request("DELETE", "/v1/robots/ur5/gravity"), 405),
    "media type": (request("POST", "/v1/robots/ur5/gravity", b"q=1", "text/plain"), 415),
    "answer too large": (
        request(
            "POST",
            "/v1/robots/ur5/mass-matrix",
            b'{"q": [' + b",".join([b"[0,0,0,0,0,0]"] * 400) + b"]}",
        ),
        413,
    ),
}


@pytest.mark.parametrize("case", KEPT_ALIVE)
def test_the_connection_stays_usable_after_an_error(base: str, case: str) -> None:
    raw, status = KEPT_ALIVE[case]
    with connect(base) as sock:
        for _ in range(2):  # twice on the same connection, then a valid request
            sock.sendall(raw)
            answer = read_answer(sock)
            assert answer.status == status, answer.body
            assert answer.headers["content-type"] == "application/problem+json"
            assert not answer.closes, answer.headers
        _assert_usable_or_closed(sock, False, base)


def test_a_413_by_content_length_says_close_and_closes_cleanly(base: str) -> None:
    """The body is refused before it is read: the unread rest cannot be taken for the next
    request, so the answer says close; the client that stops sending sees the close."""
    with connect(base) as sock:
        sock.sendall(
            request("POST", "/v1/robots/ur5/gravity", b"x" * 100, content_length=10 * MAX_BODY)
        )
        answer = read_answer(sock)
        assert answer.status == 413 and answer.json()["code"] == "payload_too_large"
        assert answer.closes
        _assert_usable_or_closed(sock, True, base)


def test_a_client_that_sends_its_whole_oversized_body_reads_its_413(base: str) -> None:
    """The server keeps reading (discarding) while the client sends: no reset mid-send."""
    body = b"[" + b"0," * (4 * MAX_BODY) + b"0]"
    with connect(base) as sock:
        sock.sendall(request("POST", "/v1/robots/ur5/gravity", body))  # no BrokenPipe
        answer = read_answer(sock)
        assert answer.status == 413 and answer.closes
        assert closed_within(sock, LINGER_S + 3) is not None
    with httpx.Client(base_url=base) as client:  # and as a library client sees it
        r = client.post(
            "/v1/robots/ur5/gravity", content=body, headers={"content-type": "application/json"}
        )
        assert r.status_code == 413 and r.json()["code"] == "payload_too_large"
        assert client.post("/v1/robots/ur5/gravity", json={"q": [0] * 6}).status_code == 200


def test_an_error_answered_before_the_body_is_sent(base: str) -> None:
    """Headers first, the answer comes before the body (an unknown route reads no body):
    the answer says close, as the body still to come would be read as the next request."""
    with connect(base) as sock:
        sock.sendall(request("POST", "/nope", None, content_length=20))
        answer = read_answer(sock)
        assert answer.status == 404 and answer.json()["code"] == "not_found"
        assert answer.closes
        sock.sendall(b"x" * 20)  # the client may still send its body: no reset
        _assert_usable_or_closed(sock, True, base)


def test_expect_100_continue_refused_up_front(base: str) -> None:
    with connect(base) as sock:
        sock.sendall(
            request(
                "POST",
                "/v1/robots/ur5/gravity",
                None,
                content_length=10 * MAX_BODY,
                headers=("expect: 100-continue",),
            )
        )
        answer = read_answer(sock)
        assert answer.status == 413 and answer.closes
        _assert_usable_or_closed(sock, True, base)


@pytest.mark.parametrize(
    "garbage",
    [
        b"GARBAGE\r\n\r\n",
        b"GET / HTTP/1.1\r\nbad header line\r\n\r\n",
        b"GET / HTTP/1.1\r\nhost: x\r\ncontent-length: -5\r\n\r\n",
        b"GET /\x00 HTTP/1.1\r\n\r\n",
        b"GET /\xff HTTP/1.1\r\nhost: x\r\n\r\n",
        b"POST /v1/robots/ur5/gravity HTTP/1.1\r\ncontent-length: abc\r\n\r\n",
        b"POST /v1/robots/ur5/gravity HTTP/1.1\r\ntransfer-encoding: chunked\r\n"
        b"content-type: application/json\r\n\r\nzz\r\n",  # broken chunk framing in the body
    ],
)
def test_malformed_requests_get_a_problem_json_400(base: str, garbage: bytes) -> None:
    with connect(base) as sock:
        sock.sendall(garbage)
        answer = read_answer(sock)
        assert answer.status == 400, answer
        assert answer.headers["content-type"] == "application/problem+json"
        assert answer.json()["code"] == "bad_request" and answer.closes
        assert closed_within(sock, LINGER_S + 3) is not None


def test_httpx_with_one_connection_after_every_kind_of_error(base: str) -> None:
    limits = httpx.Limits(max_connections=1, max_keepalive_connections=1)
    with httpx.Client(base_url=base, limits=limits) as client:
        for _ in range(3):
            assert client.post("/v1/robots/ur5/gravity", json={"q": [0]}).status_code == 422
            assert client.get("/nope").status_code == 404
            assert (
                client.post(
                    "/v1/robots/ur5/gravity",
                    content=b"x" * (2 * MAX_BODY),
                    headers={"content-type": "application/json"},
                ).status_code
                == 413
            )
            assert (
                client.post(
                    "/v1/robots/ur5/gravity", content=b"q", headers={"content-type": "text/plain"}
                ).status_code
                == 415
            )
            r = client.post("/v1/robots/ur5/gravity", json={"q": [0] * 6})
            assert r.status_code == 200 and len(r.json()["gravity"]) == 6


def test_an_unexpected_failure_answers_500_and_keeps_the_connection(tmp_path) -> None:
    """A 500 is a complete answer: the connection stays usable (uvicorn closed it without
    saying so when the exception reached it), and the failure is logged once."""
    app = create_app(Settings(catalog="ur5", data_dir=tmp_path))

    async def boom() -> None:
        raise RuntimeError("a bug")

    app.add_api_route("/boom", boom)
    config = uvicorn.Config(app, port=0, http=HardenedHttpToolsProtocol, log_level="warning")
    server = uvicorn.Server(config)
    thread = threading.Thread(target=asyncio.run, args=(server.serve(),), daemon=True)
    thread.start()
    deadline = time.monotonic() + 60
    while not (server.started and app.state.registry.ready):
        assert time.monotonic() < deadline and thread.is_alive()
        time.sleep(0.05)
    port = server.servers[0].sockets[0].getsockname()[1]
    try:
        with connect(f"http://127.0.0.1:{port}") as sock:
            for _ in range(2):
                sock.sendall(request("GET", "/boom"))
                answer = read_answer(sock)
                assert answer.status == 500 and answer.json()["code"] == "internal_error"
                assert not answer.closes
            _assert_usable_or_closed(sock, False, f"http://127.0.0.1:{port}")
    finally:
        server.should_exit = True
        thread.join(30)
