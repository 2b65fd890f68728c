"""WebSocket streams: many small dynamics requests of one robot over one connection.

    with client.stream("ur5") as s:
        tau = s.inverse_dynamics(q, v, a)      # same arguments as the client's, minus robot_id

Every dynamics method of the client exists on a stream. Requests are answered in order; an
error raises the same `APIError` subclass as over HTTP and the stream stays usable. Streams
need the `websockets` package: `pip install 'robodyn[stream]'`.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from types import TracebackType
from typing import Any

import httpx

from robodyn import binary, core
from robodyn._calls import BUILDERS, STREAMED
from robodyn._calls.robots import robot
from robodyn._methods import SYNC
from robodyn.errors import ResponseFormatError, TransportError, error_class

STREAM_PATH = "/v1/robots/{robot_id}/stream"


def _require_websockets() -> None:
    try:
        import websockets  # noqa: F401
    except ImportError:
        raise ImportError(
            "streams need the 'websockets' package: pip install 'robodyn[stream]'"
        ) from None


def stream_url(base_url: str, robot_id: str) -> str:
    """The ws:// (or wss://) URL of a robot's stream."""
    call = robot(robot_id)  # checks and quotes the id
    scheme, rest = base_url.split("://", 1)
    return f"{'wss' if scheme == 'https' else 'ws'}://{rest}{call.path}/stream"


def message(call: core.Call[Any], use_binary: bool | None) -> str | bytes:
    """The stream message of a client call: JSON text, or the binary form for large inputs."""
    call.check_finite()
    if call.binary(use_binary):
        return binary.encode(call.arrays or {}, {**(call.json or {}), "quantity": call.quantity})
    return core.encode({"quantity": call.quantity, **call.json_body()}).decode()


def answer(call: core.Call[Any], reply: str | bytes) -> Any:
    """The result of `call` from the stream's reply; raises the APIError of a problem."""
    body: Any = binary.decode(reply) if isinstance(reply, bytes) else json.loads(reply)
    if isinstance(body, dict) and isinstance(body.get("code"), str) and "status" in body:
        status = int(body["status"])
        raise error_class(status, body["code"])(
            status, body["code"], str(body.get("title")), str(body.get("detail")), body, None
        )
    try:
        return call.read(200, body)
    except (KeyError, ValueError, TypeError, IndexError) as exc:
        raise ResponseFormatError(
            f"stream answer of {call.path} is unexpected: {exc!s}", status=200, body=body
        ) from exc


@contextmanager
def _wrapped(robot_id: str) -> Iterator[None]:
    """A closed or failed connection becomes `robodyn.TransportError`."""
    from websockets.exceptions import InvalidStatus, WebSocketException

    try:
        yield
    except InvalidStatus as exc:  # the handshake was refused with an HTTP answer
        raise core.api_error(
            httpx.Response(
                exc.response.status_code,
                headers=list(exc.response.headers.raw_items()),
                content=bytes(exc.response.body or b""),
            )
        ) from exc
    except (WebSocketException, OSError) as exc:
        raise TransportError(
            f"the stream of {robot_id!r} failed ({type(exc).__name__}): {exc}",
            method="WEBSOCKET",
            url=STREAM_PATH,
        ) from exc


def _method(name: str, send: Callable[..., Any]) -> Callable[..., Any]:
    build = BUILDERS[name]

    def method(self: Any, *args: Any, **kwargs: Any) -> Any:
        return send(self, build(self.robot_id, *args, **kwargs))

    method.__name__ = name
    method.__doc__ = next(getattr(cls, name).__doc__ for cls in SYNC if hasattr(cls, name))
    return method


class Stream:
    """A blocking stream of one robot (from `Client.stream`); a context manager."""

    def __init__(
        self,
        url: str,
        robot_id: str,
        headers: dict[str, str],
        use_binary: bool | None,
        open_timeout: float | None,
        unix_socket: str | None = None,
    ) -> None:
        _require_websockets()
        from websockets.sync.client import connect, unix_connect

        self.robot_id, self._use_binary = robot_id, use_binary
        self._exit = ExitStack()
        options: dict[str, Any] = dict(
            additional_headers=headers, open_timeout=open_timeout, max_size=None, compression=None
        )
        with _wrapped(robot_id):
            self._ws = self._exit.enter_context(
                connect(url, **options)
                if unix_socket is None
                else unix_connect(unix_socket, url, **options)
            )

    def _send(self, call: core.Call[Any]) -> Any:
        with _wrapped(self.robot_id):
            self._ws.send(message(call, self._use_binary))
            reply = self._ws.recv()
        return answer(call, reply)

    def close(self) -> None:
        self._exit.close()

    def __enter__(self) -> Stream:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


class AsyncStream:
    """An asyncio stream of one robot (from `AsyncClient.stream`); an async context manager."""

    def __init__(
        self,
        url: str,
        robot_id: str,
        headers: dict[str, str],
        use_binary: bool | None,
        open_timeout: float | None,
        unix_socket: str | None = None,
    ) -> None:
        _require_websockets()
        self.robot_id, self._use_binary = robot_id, use_binary
        self._url, self._headers, self._open_timeout = url, headers, open_timeout
        self._unix_socket = unix_socket
        self._ws: Any = None

    async def _send(self, call: core.Call[Any]) -> Any:
        if self._ws is None:
            raise RuntimeError("use the stream as `async with client.stream(robot_id) as s:`")
        with _wrapped(self.robot_id):
            await self._ws.send(message(call, self._use_binary))
            reply = await self._ws.recv()
        return answer(call, reply)

    async def close(self) -> None:
        if self._ws is not None:
            await self._ws.close()

    async def __aenter__(self) -> AsyncStream:
        from websockets.asyncio.client import connect, unix_connect

        options: dict[str, Any] = dict(
            additional_headers=self._headers,
            open_timeout=self._open_timeout,
            max_size=None,
            compression=None,
        )
        with _wrapped(self.robot_id):
            self._ws = await (
                connect(self._url, **options)
                if self._unix_socket is None
                else unix_connect(self._unix_socket, self._url, **options)
            )
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()


def _add_methods() -> None:
    def send_sync(self: Stream, call: core.Call[Any]) -> Any:
        return self._send(call)

    async def send_async(self: AsyncStream, call: core.Call[Any]) -> Any:
        return await self._send(call)

    for name in STREAMED:
        setattr(Stream, name, _method(name, send_sync))
        setattr(AsyncStream, name, _method(name, send_async))


_add_methods()
__all__ = ["AsyncStream", "Stream"]
