"""HTTP/1.1 spoken by hand over a socket, as a hostile or careless client would: requests built
byte by byte, answers read strictly by their framing (Content-Length)."""

from __future__ import annotations

import socket
import time
from dataclasses import dataclass

import orjson

GOOD_BODY = b'{"q": [0, 0, 0, 0, 0, 0]}'


@dataclass
class Answer:
    status: int
    headers: dict[str, str]
    body: bytes

    def json(self) -> dict:
        return orjson.loads(self.body)

    @property
    def closes(self) -> bool:
        return "close" in self.headers.get("connection", "").lower()


def request(
    method: str,
    path: str,
    body: bytes | None = None,
    content_type: str | None = "application/json",
    headers: tuple[str, ...] = (),
    content_length: int | None = None,
) -> bytes:
    lines = [f"{method} {path} HTTP/1.1", "host: test"]
    if body is not None or content_length is not None:
        length = len(body or b"") if content_length is None else content_length
        lines.append(f"content-length: {length}")
        if content_type:
            lines.append(f"content-type: {content_type}")
    lines += headers
    return ("\r\n".join(lines) + "\r\n\r\n").encode() + (body or b"")


def good_request() -> bytes:
    return request("POST", "/v1/robots/ur5/gravity", GOOD_BODY)


def connect(base: str, timeout: float = 10.0) -> socket.socket:
    host, port = base.removeprefix("http://").split(":")
    sock = socket.create_connection((host, int(port)), timeout=timeout)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return sock


def read_answer(sock: socket.socket) -> Answer:
    """One whole answer; ConnectionError when the server closes before it is complete."""
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = sock.recv(65536)
        if not chunk:
            raise ConnectionError(f"closed before an answer's head ({data[:200]!r})")
        data += chunk
    head, _, rest = data.partition(b"\r\n\r\n")
    status_line, *header_lines = head.decode("latin-1").split("\r\n")
    headers = {}
    for line in header_lines:
        name, _, value = line.partition(":")
        headers[name.strip().lower()] = value.strip()
    length = int(headers.get("content-length", "0"))
    while len(rest) < length:
        chunk = sock.recv(65536)
        if not chunk:
            raise ConnectionError("closed in the middle of an answer's body")
        rest += chunk
    assert len(rest) == length, "more bytes than the answer's Content-Length"
    return Answer(int(status_line.split()[1]), headers, rest)


def closed_within(sock: socket.socket, seconds: float) -> float | None:
    """Seconds until the server closes `sock` (EOF or reset), reading and discarding what it
    sends; None if still open after `seconds`."""
    started = time.monotonic()
    sock.settimeout(0.2)
    while time.monotonic() - started < seconds:
        try:
            if not sock.recv(65536):
                return time.monotonic() - started
        except TimeoutError:
            continue
        except OSError:
            return time.monotonic() - started
    return None
