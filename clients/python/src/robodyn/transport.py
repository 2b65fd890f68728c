"""Connection settings shared by both clients: base URL, headers, timeouts, error wrapping,
and retries of requests a busy or restarting server could not answer."""

from __future__ import annotations

import os
import time
from collections.abc import AsyncIterator, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import httpx
import stamina

from robodyn import __version__, binary, shared_memory
from robodyn.core import PROGRESS_MEDIA_TYPE, Body, Call
from robodyn.errors import ServiceUnavailableError, TimeoutError, TransportError

DEFAULT_URL = "http://127.0.0.1:8000"
UNIX_SCHEME = "unix://"
UNIX_BASE_URL = "http://localhost"  # the URL of requests sent through a Unix socket
URL_ENV = "ROBODYN_URL"

DEFAULT_TIMEOUT: httpx.Timeout = httpx.Timeout(60.0, connect=5.0)
"""Seconds: 5 to connect, 60 to send, to wait for the answer and to get a pooled connection.
Large batches take longer: pass `timeout=` to the client (a number or an `httpx.Timeout`)."""

DEFAULT_LIMITS = httpx.Limits(max_connections=20, max_keepalive_connections=10)

TimeoutLike = float | httpx.Timeout | None


@dataclass(frozen=True)
class Retry:
    """How a client retries a request the server could not answer: a 503 (`not_ready`,
    `overloaded`: nothing was computed) or a failed connection. Every robodyn request may be
    sent again — dynamics are computations, uploads are keyed by their content — except
    `delete`, which is retried only when it surely did not reach the server (503, refused
    connection). Timeouts while waiting for an answer are not retried.

    At most `attempts` tries (the first included) within `timeout` seconds from the first
    failure. The wait before the next try is the server's `Retry-After` when it gives one
    (never past the budget: a longer one ends the retries at once), else exponential from
    `wait_initial` up to `wait_max` seconds, with up to `wait_jitter` seconds of random jitter
    (stamina's backoff). The last error is raised.
    """

    attempts: int = 5
    timeout: float = 30.0
    wait_initial: float = 0.1
    wait_max: float = 5.0
    wait_jitter: float = 0.5


DEFAULT_RETRY: Retry = Retry()
RETRIED = (ServiceUnavailableError, TransportError)
"""The failures `retry_context` may retry (it decides which by their cause)."""
_SENT_FAILURES = (httpx.RemoteProtocolError, httpx.ReadError, httpx.WriteError)
_UNSENT_FAILURES = (httpx.ConnectError, httpx.ConnectTimeout, httpx.PoolTimeout)


def retry_context(call: Call[Any], retry: Retry | None) -> Any:
    """The `stamina.retry_context` of `call` under `retry` (one attempt for None):
    `for attempt in retry_context(...): with attempt: ...` (or `async for`)."""
    if retry is None:
        return stamina.retry_context(on=(), attempts=1, timeout=None)
    deadline = time.monotonic() + retry.timeout

    def backoff(exc: Exception) -> bool | float:
        """False: raise `exc`; True: stamina's backoff; a number: wait that long."""
        if isinstance(exc, ServiceUnavailableError):
            if exc.retry_after is None:
                return True
            wait = max(exc.retry_after, 0.0)
            return wait if time.monotonic() + wait < deadline else False
        if isinstance(exc, TransportError):
            cause = exc.__cause__
            return isinstance(cause, _UNSENT_FAILURES) or (
                call.idempotent and isinstance(cause, _SENT_FAILURES)
            )
        return False

    return stamina.retry_context(
        on=backoff,
        attempts=retry.attempts,
        timeout=retry.timeout,
        wait_initial=retry.wait_initial,
        wait_max=retry.wait_max,
        wait_jitter=retry.wait_jitter,
    )


@dataclass(frozen=True)
class Settings:
    """What every request of one client carries: its absolute base URL and headers."""

    base_url: str
    headers: Mapping[str, str]
    use_binary: bool | None = None  # None: the binary form for large batches only
    fill: str | None = None  # sent with inputs keyed by joint name
    unix_socket: str | None = None  # the server's Unix socket (a unix:// URL), else None

    @property
    def address(self) -> str:
        """The server as the user named it: `unix:///path` for a Unix socket, else the URL."""
        return f"unix://{self.unix_socket}" if self.unix_socket else self.base_url

    def prepare(
        self, call: Call[Any], with_progress: bool = False
    ) -> tuple[str, dict[str, str], Body | None]:
        """The absolute URL, headers and body of `call` (bytes, or a list of parts sent one
        after the other under one Content-Length); `with_progress`: the answer asked for as the
        server's progress stream (its last line the JSON answer)."""
        headers = dict(self.headers)
        content, media_type = call.body(self.use_binary, self.fill)
        if isinstance(content, list):
            headers["Content-Length"] = str(sum(len(part) for part in content))
        if media_type is not None:
            headers["Content-Type"] = media_type
            if media_type == binary.MEDIA_TYPE:
                headers["Accept"] = f"{binary.MEDIA_TYPE}, application/problem+json"
        if with_progress:
            headers["Accept"] = f"{PROGRESS_MEDIA_TYPE}, application/problem+json"
        return self.base_url + call.path, headers, content


def settings(
    base_url: str | None,
    api_key: str | None,
    http_client: httpx.Client | httpx.AsyncClient | None,
    headers: Mapping[str, str] | None,
    use_binary: bool | None = None,
    fill: str | None = None,
) -> Settings:
    """Resolve the base URL (argument, else the injected client's, else $ROBODYN_URL, else
    http://127.0.0.1:8000) and the headers sent with each request. A `unix:///path` URL names
    the server's Unix socket: requests then go to http://localhost through it."""
    if base_url is None and http_client is not None and str(http_client.base_url):
        base_url = str(http_client.base_url)
    if base_url is None:
        base_url = os.environ.get(URL_ENV) or DEFAULT_URL
    unix_socket = unix_socket_of(base_url)
    if unix_socket is not None:
        base_url = UNIX_BASE_URL
    url = httpx.URL(base_url)
    if url.scheme not in ("http", "https") or not url.host:
        raise ValueError(
            "base_url must be an http:// or https:// URL with a host, or unix:// and a "
            f"socket's path, not {base_url!r}"
        )
    sent = {"Accept": "application/json", "User-Agent": f"robodyn-python/{__version__}"}
    sent.update(headers or {})
    if api_key is not None:
        if not api_key or any(c in api_key for c in "\r\n"):
            raise ValueError("api_key must be a non-empty single-line string")
        sent["Authorization"] = f"Bearer {api_key}"
    if fill is not None and (not isinstance(fill, str) or not fill):
        raise ValueError('fill must be "neutral" or the name of a reference configuration')
    return Settings(
        base_url=str(url).rstrip("/"),
        headers=sent,
        use_binary=use_binary,
        fill=fill,
        unix_socket=unix_socket,
    )


def unix_socket_of(base_url: str) -> str | None:
    """The socket path of a `unix:///path` URL (None for any other URL)."""
    if not base_url.startswith(UNIX_SCHEME):
        return None
    path = base_url[len(UNIX_SCHEME) :]
    if not path.startswith("/") or path.endswith("/"):
        raise ValueError(
            f"a Unix socket URL is unix:// and the socket's absolute path, not {base_url!r}"
        )
    return path


def http_transport(settings: Settings) -> httpx.HTTPTransport | None:
    """The transport of a client's own `httpx.Client`: through the Unix socket, or None
    (httpx's default, TCP)."""
    if settings.unix_socket is None:
        return None
    return httpx.HTTPTransport(uds=settings.unix_socket, limits=DEFAULT_LIMITS)


def async_http_transport(settings: Settings) -> httpx.AsyncHTTPTransport | None:
    """`http_transport` for an `httpx.AsyncClient`."""
    if settings.unix_socket is None:
        return None
    return httpx.AsyncHTTPTransport(uds=settings.unix_socket, limits=DEFAULT_LIMITS)


def shared_body(
    shared: shared_memory.SharedMemory | None,
    call: Call[Any],
    headers: dict[str, str],
    body: Body | None,
) -> tuple[shared_memory.Segment | None, Body | None]:
    """Over a Unix socket (`shared` is the client's `SharedMemory`), a binary body of
    `shared_memory.SHARED_FROM` bytes or more written into shared memory, and the request's
    headers naming it: (the segment, an empty body). Otherwise, or when no segment can be
    made: (None, `body`), its arrays checked finite (`Call.check_finite`)."""
    if (
        shared is None
        or not call.shared_memory
        or not isinstance(body, list)
        or headers.get("Content-Type") != binary.MEDIA_TYPE
        or sum(len(part) for part in body) < shared_memory.SHARED_FROM
    ):
        segment = None
    else:
        segment = shared.segment(body)
    if segment is None:
        if isinstance(body, list):
            call.check_finite()  # (sent as it is: checked here, before sending)
        return None, body
    headers["Content-Length"] = "0"
    headers[shared_memory.BODY_HEADER] = segment.header
    if segment.room is not None:
        headers[shared_memory.ROOM_HEADER] = segment.room
    return segment, b""


def refused_shared_body(
    call: Call[Any], segment: shared_memory.Segment | None, status: int
) -> None:
    """A body sent through shared memory unchecked that the server refused (422): the
    client's own `InputError` when it holds a non-finite number, as over TCP."""
    if segment is not None and status == 422:
        call.check_finite()


def shared_answer(
    segment: shared_memory.Segment | None, response: httpx.Response
) -> memoryview | None:
    """The answer the server wrote into shared memory (named in its headers): lent from the
    client's answer room or copied out; None when it sent its answer through the socket.
    Called once the response is read whole (the server is done with the request)."""
    if segment is None:
        return None
    segment.settled = True
    if not 200 <= response.status_code <= 299:
        return None
    value = response.headers.get(shared_memory.ANSWER_HEADER)
    return None if value is None else segment.answer(value, response.status_code)


async def parts_async(parts: list[bytes | memoryview]) -> AsyncIterator[bytes | memoryview]:
    """A body in parts as the AsyncClient sends it (httpx takes only async iterables there)."""
    for part in parts:
        yield part


def timeout_of(timeout: TimeoutLike) -> httpx.Timeout:
    return timeout if isinstance(timeout, httpx.Timeout) else httpx.Timeout(timeout)


@contextmanager
def wrapped(method: str, url: str) -> Iterator[None]:
    """Turn httpx's transport failures into `robodyn.TransportError` / `robodyn.TimeoutError`."""
    try:
        yield
    except httpx.TimeoutException as exc:
        raise TimeoutError(
            f"{method} {url} timed out ({type(exc).__name__}): {exc}", method=method, url=url
        ) from exc
    except httpx.RequestError as exc:
        raise TransportError(
            f"{method} {url} failed ({type(exc).__name__}): {exc}", method=method, url=url
        ) from exc
