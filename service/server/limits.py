"""The limits of the server's HTTP connections (service/server/protocol.py): timeouts and the
connection cap from the settings, counters of the connections the protocol closed, and the
complete answers it writes itself. Kept apart from the protocol so that the metrics can read
the counters without importing uvicorn's internals."""

from __future__ import annotations

import functools
import resource
from dataclasses import dataclass

import orjson

from service.errors import problem_document

FD_RESERVE = 64  # file descriptors kept for other than connections
LINGER_S = 2.0  # how long a closing connection keeps reading (and discarding) what still comes

# Connections closed by the protocol, by reason (exported as robodyn_connections_closed_total).
CLOSED: dict[str, int] = {
    "header_timeout": 0,
    "body_timeout": 0,
    "send_timeout": 0,
    "evicted": 0,
    "refused": 0,
    "bad_request": 0,
}


@dataclass(frozen=True)
class ConnectionLimits:
    """The connection settings of this process (from `Settings`, read once: the defaults
    are the settings' own)."""

    header_timeout_s: float
    body_timeout_s: float
    send_timeout_s: float
    max_connections: int


@functools.cache
def connection_limits() -> ConnectionLimits:
    from service.settings import Settings  # at first connection, after the workers' start

    s = Settings()
    return ConnectionLimits(
        s.header_timeout_s,
        s.body_timeout_s,
        s.send_timeout_s,
        min(s.max_connections, _descriptors_for_connections()),
    )


def _descriptors_for_connections() -> int:
    """File descriptors this process may spend on connections: its soft RLIMIT_NOFILE less
    `FD_RESERVE` for everything else (listening socket, logs, pipes, store files, builders).
    Past the descriptor limit, accepting fails before the cap could act."""
    soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft == resource.RLIM_INFINITY:
        return 1 << 30
    return max(soft - FD_RESERVE, 16)


def problem_answer(
    status: int, reason: bytes, code: str, title: str, detail: str, extra_headers: bytes = b""
) -> bytes:
    """A complete HTTP/1.1 problem+json answer that closes the connection."""
    body = orjson.dumps(problem_document(code, title, status, detail))
    return (
        b"HTTP/1.1 %d %s\r\ncontent-type: application/problem+json\r\n"
        b"content-length: %d\r\nconnection: close\r\n%s\r\n"
        % (status, reason, len(body), extra_headers)
    ) + body
