"""The private parts of uvicorn that service/server/protocol.py relies on are still there.

`HardenedHttpToolsProtocol` subclasses uvicorn's `HttpToolsProtocol` and swaps the class of its
`RequestResponseCycle`; pyproject.toml pins uvicorn to the range these tests were run with. A
newer uvicorn that renames, removes or re-signs any of these fails here with a message naming
what moved, before anything subtler breaks in production."""

from __future__ import annotations

import asyncio
import inspect
from typing import Any

import pytest
import uvicorn
from uvicorn.protocols.http import flow_control, httptools_impl
from uvicorn.server import ServerState

from service.server.protocol import CoalescedWrites, GuardedCycle, HardenedHttpToolsProtocol

MOVED = (
    "uvicorn {version}: {what} moved; service/server/protocol.py relies on it — adapt the "
    "protocol, then widen the uvicorn pin in pyproject.toml"
)

PROTOCOL_METHODS = {  # name -> parameters (after self) the subclass overrides or calls
    "__init__": ["config", "server_state", "app_state", "_loop"],
    "connection_made": ["transport"],
    "connection_lost": ["exc"],
    "data_received": ["data"],
    "on_message_begin": [],
    "on_headers_complete": [],
    "on_body": ["body"],
    "on_message_complete": [],
    "on_response_complete": [],
    "send_400_response": ["msg"],
    "pause_writing": [],
    "resume_writing": [],
}
PROTOCOL_ATTRIBUTES = (
    "config",
    "loop",
    "transport",
    "flow",
    "cycle",
    "connections",
    "server_state",
    "pipeline",
    "parser",
)
CYCLE_ATTRIBUTES = (
    "transport",
    "keep_alive",
    "more_body",
    "response_started",
    "response_complete",
    "disconnected",
    "scope",
)


def _moved(what: str) -> str:
    return MOVED.format(version=uvicorn.__version__, what=what)


@pytest.mark.parametrize("name", PROTOCOL_METHODS)
def test_protocol_methods_keep_their_signatures(name: str) -> None:
    method = getattr(httptools_impl.HttpToolsProtocol, name, None)
    assert callable(method), _moved(f"HttpToolsProtocol.{name}")
    parameters = list(inspect.signature(method).parameters)[1:]
    assert parameters == PROTOCOL_METHODS[name], _moved(
        f"the parameters of HttpToolsProtocol.{name} ({parameters})"
    )


def test_the_cycle_class_and_its_send() -> None:
    cycle = getattr(httptools_impl, "RequestResponseCycle", None)
    assert cycle is not None, _moved("httptools_impl.RequestResponseCycle")
    assert inspect.iscoroutinefunction(cycle.send), _moved("RequestResponseCycle.send")
    assert list(inspect.signature(cycle.send).parameters) == ["self", "message"], _moved(
        "the parameters of RequestResponseCycle.send"
    )
    assert GuardedCycle.__mro__[1] is cycle
    assert inspect.iscoroutinefunction(cycle.send_500_response), _moved(
        "RequestResponseCycle.send_500_response"
    )
    assert list(inspect.signature(cycle.run_asgi).parameters) == ["self", "app"], _moved(
        "RequestResponseCycle.run_asgi (which calls send_500_response)"
    )
    assert hasattr(flow_control.FlowControl(None), "read_paused"), _moved(  # type: ignore[arg-type]
        "FlowControl.read_paused"
    )


class FakeTransport:
    def __init__(self) -> None:
        self.written = b""
        self.closed = False

    def write(self, data: bytes) -> None:
        self.written += bytes(data)

    def writelines(self, chunks: list[bytes]) -> None:
        self.written += b"".join(chunks)

    def close(self) -> None:
        self.closed = True

    def is_closing(self) -> bool:
        return self.closed

    def can_write_eof(self) -> bool:
        return False

    def pause_reading(self) -> None: ...

    def resume_reading(self) -> None: ...

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        return {"peername": ("127.0.0.1", 1), "sockname": ("127.0.0.1", 2)}.get(name, default)


async def _app(scope: dict[str, Any], receive: Any, send: Any) -> None:
    if scope["path"] == "/fail":
        raise RuntimeError("fails before answering")
    body = b"hello"
    await send(
        {"type": "http.response.start", "status": 200, "headers": [(b"content-length", b"5")]}
    )
    await send({"type": "http.response.body", "body": body})


def test_a_request_goes_through_the_subclass_as_expected() -> None:
    """The attributes read and written exist on a live protocol and cycle, and an answer made
    through them is framed as uvicorn frames it (one write, content-length kept)."""

    async def run() -> tuple[HardenedHttpToolsProtocol, Any, FakeTransport]:
        config = uvicorn.Config(_app, http=HardenedHttpToolsProtocol, lifespan="off")
        protocol = HardenedHttpToolsProtocol(config, ServerState(), {})
        for name in PROTOCOL_ATTRIBUTES:
            assert hasattr(protocol, name), _moved(f"the attribute HttpToolsProtocol.{name}")
        transport = FakeTransport()
        protocol.connection_made(transport)  # type: ignore[arg-type]
        protocol.data_received(b"GET / HTTP/1.1\r\nhost: x\r\n\r\n")
        cycle = protocol.cycle
        for _ in range(20):
            await asyncio.sleep(0)
        return protocol, cycle, transport

    _, cycle, transport = asyncio.run(run())
    assert type(cycle) is GuardedCycle and isinstance(cycle.transport, CoalescedWrites)
    for name in CYCLE_ATTRIBUTES:
        assert hasattr(cycle, name), _moved(f"the attribute RequestResponseCycle.{name}")
    assert cycle.response_complete and not transport.closed
    assert transport.written.startswith(b"HTTP/1.1 200 OK\r\n")
    assert transport.written.endswith(b"content-length: 5\r\n\r\nhello")


def test_uvicorn_run_takes_the_options_the_server_passes() -> None:
    parameters = inspect.signature(uvicorn.run).parameters
    for name in (
        "http",
        "timeout_keep_alive",
        "timeout_graceful_shutdown",
        "factory",
        "log_config",
        "access_log",
    ):
        assert name in parameters, _moved(f"uvicorn.run({name}=...)")


def test_uvicorns_last_resort_500_is_problem_json() -> None:
    async def run() -> FakeTransport:
        config = uvicorn.Config(
            _app, http=HardenedHttpToolsProtocol, lifespan="off", log_level="critical"
        )
        protocol = HardenedHttpToolsProtocol(config, ServerState(), {})
        transport = FakeTransport()
        protocol.connection_made(transport)  # type: ignore[arg-type]
        protocol.data_received(b"GET /fail HTTP/1.1\r\nhost: x\r\n\r\n")
        for _ in range(20):
            await asyncio.sleep(0)
        return transport

    transport = asyncio.run(run())
    head, _, body = transport.written.partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 500 ") and b"application/problem+json" in head
    assert b"connection: close" in head and b'"code":"internal_error"' in body
