"""Connection settings shared by both clients: base URL, headers, timeouts, error wrapping."""

from __future__ import annotations

import os
from collections.abc import AsyncIterator, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import httpx

from robodyn import __version__, binary
from robodyn.core import Body, Call
from robodyn.errors import TimeoutError, TransportError

DEFAULT_URL = "http://127.0.0.1:8000"
URL_ENV = "ROBODYN_URL"

DEFAULT_TIMEOUT: httpx.Timeout = httpx.Timeout(60.0, connect=5.0)
"""Seconds: 5 to connect, 60 to send, to wait for the answer and to get a pooled connection.
Large batches take longer: pass `timeout=` to the client (a number or an `httpx.Timeout`)."""

DEFAULT_LIMITS = httpx.Limits(max_connections=20, max_keepalive_connections=10)

TimeoutLike = float | httpx.Timeout | None


@dataclass(frozen=True)
class Settings:
    """What every request of one client carries: its absolute base URL and headers."""

    base_url: str
    headers: Mapping[str, str]
    use_binary: bool | None = None  # None: the binary form for large batches only

    def prepare(self, call: Call[Any]) -> tuple[str, dict[str, str], Body | None]:
        """The absolute URL, headers and body of `call` (bytes, or a list of parts sent one
        after the other under one Content-Length)."""
        headers = dict(self.headers)
        content, media_type = call.body(self.use_binary)
        if isinstance(content, list):
            headers["Content-Length"] = str(sum(len(part) for part in content))
        if media_type is not None:
            headers["Content-Type"] = media_type
            if media_type == binary.MEDIA_TYPE:
                headers["Accept"] = f"{binary.MEDIA_TYPE}, application/problem+json"
        return self.base_url + call.path, headers, content


def settings(base_url: str | None, api_key: str | None, http_client: httpx.Client |
             httpx.AsyncClient | None, headers: Mapping[str, str] | None,
             use_binary: bool | None = None) -> Settings:
    """Resolve the base URL (argument, else the injected client's, else $ROBODYN_URL, else
    http://127.0.0.1:8000) and the headers sent with each request."""
    if base_url is None and http_client is not None and str(http_client.base_url):
        base_url = str(http_client.base_url)
    if base_url is None:
        base_url = os.environ.get(URL_ENV) or DEFAULT_URL
    url = httpx.URL(base_url)
    if url.scheme not in ("http", "https") or not url.host:
        raise ValueError(f"base_url must be an http:// or https:// URL with a host, "
                         f"not {base_url!r}")
    sent = {"Accept": "application/json", "User-Agent": f"robodyn-python/{__version__}"}
    sent.update(headers or {})
    if api_key is not None:
        if not api_key or any(c in api_key for c in "\r\n"):
            raise ValueError("api_key must be a non-empty single-line string")
        sent["Authorization"] = f"Bearer {api_key}"
    return Settings(base_url=str(url).rstrip("/"), headers=sent, use_binary=use_binary)


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
        raise TimeoutError(f"{method} {url} timed out ({type(exc).__name__}): {exc}",
                           method=method, url=url) from exc
    except httpx.RequestError as exc:
        raise TransportError(f"{method} {url} failed ({type(exc).__name__}): {exc}",
                             method=method, url=url) from exc
