"""The HTTP protocol of `python -m service` (service/server/protocol.py): the writes of one
request within one event-loop step leave in one system call, in order; closing sends what is
pending first; a real server answers keep-alive and pipelined requests in order. (WebSocket
upgrades through it are exercised by the client's stream tests against `python -m service`.)"""

from __future__ import annotations

import asyncio
import socket
from typing import Any

import pytest
import uvicorn

from service.server.protocol import CoalescedWrites, HardenedHttpToolsProtocol


class FakeTransport:
    def __init__(self) -> None:
        self.writes: list[bytes] = []
        self.closed = False

    def write(self, data: bytes) -> None:
        assert not self.closed
        self.writes.append(bytes(data))

    def close(self) -> None:
        self.closed = True

    def is_closing(self) -> bool:
        return self.closed

    def writelines(self, chunks: list[bytes]) -> None:
        self.write(b"".join(chunks))  # as asyncio's default: one write

    def get_extra_info(self, name: str) -> Any:
        return f"info:{name}"


def test_writes_of_one_step_leave_together_after_it() -> None:
    async def run() -> FakeTransport:
        transport = FakeTransport()
        writes = CoalescedWrites(transport, asyncio.get_running_loop())  # type: ignore[arg-type]
        writes.write(b"HTTP/1.1 200 OK\r\n\r\n")
        writes.write(b"body")
        assert transport.writes == []  # nothing before the step ends
        await asyncio.sleep(0)
        writes.write(b"second")
        await asyncio.sleep(0)
        assert writes.get_extra_info("peername") == "info:peername"  # passed on
        return transport

    assert asyncio.run(run()).writes == [b"HTTP/1.1 200 OK\r\n\r\nbody", b"second"]


def test_close_sends_what_is_pending_first() -> None:
    async def run() -> FakeTransport:
        transport = FakeTransport()
        writes = CoalescedWrites(transport, asyncio.get_running_loop())  # type: ignore[arg-type]
        writes.write(b"last words")
        writes.close()
        await asyncio.sleep(0)  # the scheduled flush finds nothing more to send
        return transport

    transport = asyncio.run(run())
    assert transport.writes == [b"last words"] and transport.closed


async def _app(scope: dict[str, Any], receive: Any, send: Any) -> None:
    if scope["type"] == "lifespan":
        while (await receive())["type"] != "lifespan.shutdown":
            await send({"type": "lifespan.startup.complete"})
        await send({"type": "lifespan.shutdown.complete"})
        return
    body = scope["path"].encode()
    await send(
        {
            "type": "http.response.start",
            "status": 200,
            "headers": [(b"content-length", str(len(body)).encode())],
        }
    )
    await send({"type": "http.response.body", "body": body})


def _read_answers(sock: socket.socket, count: int) -> list[bytes]:
    data = b""
    while data.count(b"HTTP/1.1 200") < count or not data.endswith((b"/a", b"/b", b"/c")):
        chunk = sock.recv(65536)
        if not chunk:
            break
        data += chunk
    return [b"HTTP/1.1 200" + part for part in data.split(b"HTTP/1.1 200")[1:]]


@pytest.mark.parametrize("pipelined", [False, True])
def test_a_real_server_answers_in_order(pipelined: bool) -> None:
    async def run() -> list[bytes]:
        config = uvicorn.Config(
            _app, port=0, http=HardenedHttpToolsProtocol, log_level="warning", lifespan="off"
        )
        server = uvicorn.Server(config)
        task = asyncio.create_task(server.serve())
        while not server.started:
            await asyncio.sleep(0.01)
        port = server.servers[0].sockets[0].getsockname()[1]
        requests = [f"GET /{p} HTTP/1.1\r\nhost: x\r\n\r\n".encode() for p in "abc"]

        def client() -> list[bytes]:
            with socket.create_connection(("127.0.0.1", port)) as sock:
                if pipelined:
                    sock.sendall(b"".join(requests))
                    return _read_answers(sock, 3)
                answers = []
                for request in requests:
                    sock.sendall(request)
                    answers += _read_answers(sock, 1)
                return answers

        try:
            return await asyncio.to_thread(client)
        finally:
            server.should_exit = True
            await task

    answers = asyncio.run(run())
    assert [a.rsplit(b"\r\n\r\n", 1)[1] for a in answers] == [b"/a", b"/b", b"/c"]
    assert all(b"content-length: 2" in a for a in answers)
