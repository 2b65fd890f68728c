"""Binary bodies and answers through shared memory, for clients on the server's Unix socket
(`service.segments`; docs/binary-format.md, "Through shared memory").

A dynamics request over the Unix socket may say `Robodyn-Shared-Body: r-<32 hex> <length>` and
carry no body: its body in the binary form (the same safetensors file it would send) is the
first `length` bytes of that segment of the server's segment directory. Its binary answer is
then written to `r-<32 hex>.answer` (into the client's own file there when the request says
`Robodyn-Shared-Room: r-<32 hex>.answer`), and the answer says `Robodyn-Shared-Answer: r-<32
hex>.answer <length>` with an empty body; errors are problem+json through the socket as
always. API keys and every limit apply as to any request: the body limit
(ROBODYN_MAX_BODY_BYTES) to the length of the body in shared memory.
"""

from __future__ import annotations

import asyncio
import errno
import logging
from collections.abc import Mapping
from typing import Any

import numpy as np
from starlette.types import Scope

from service.api.encoding import binary
from service.errors import InvalidInput, Overloaded, PayloadTooLarge, UnsupportedMediaType
from service.segments import RequestSegment, SegmentDirectory, SegmentError
from service.segments.directory import SWEEP_INTERVAL_S
from service.segments.segment import SegmentTooLarge

log = logging.getLogger("robodyn")

BODY_HEADER = b"robodyn-shared-body"
ROOM_HEADER = b"robodyn-shared-room"
ANSWER_HEADER = b"robodyn-shared-answer"
_NO_ROOM = frozenset((errno.ENOSPC, errno.ENOMEM, errno.EDQUOT))


def shared_body_header(scope: Scope) -> str | None:
    """What a request says in `Robodyn-Shared-Body` (its segment's name and the body's
    length), or None."""
    for name, value in scope["headers"]:
        if name == BODY_HEADER:
            return str(value.decode("latin-1").strip())
    return None


def over_unix_socket(scope: Scope) -> bool:
    """Whether the request came over a Unix socket: ASGI's `server` is then (path, None)."""
    server = scope.get("server")
    return server is not None and len(server) == 2 and server[1] is None


def open_shared_body(scope: Scope, named: str) -> RequestSegment:
    """The body a request names in `Robodyn-Shared-Body` (`r-<32 hex> <length>`), mapped; a
    4xx domain error when it cannot be used."""
    state = scope["app"].state
    directory: SegmentDirectory | None = state.segments
    if directory is None or not over_unix_socket(scope):
        raise InvalidInput(
            "Robodyn-Shared-Body names a shared-memory segment: accepted only over the "
            "server's Unix socket (ROBODYN_UNIX_SOCKET); send the body itself"
        )
    content_type, length, room = "", "0", None
    for header, value in scope["headers"]:
        if header == b"content-type":
            content_type = value.decode("latin-1").lower()
        elif header == b"content-length":
            length = value.decode("latin-1")
        elif header == ROOM_HEADER:
            room = value.decode("latin-1").strip()
    if not content_type.startswith(binary.BINARY_MEDIA_TYPE):
        raise UnsupportedMediaType(
            "a body in shared memory is in the binary form "
            f"('Content-Type: {binary.BINARY_MEDIA_TYPE}')"
        )
    if length.strip() != "0":
        raise InvalidInput("a request with Robodyn-Shared-Body carries no body of its own")
    name, _, length = named.partition(" ")
    if not length.strip().isdigit() or len(length) > 20:
        raise InvalidInput(
            "Robodyn-Shared-Body is a segment's name and the body's length in bytes, "
            "separated by a space"
        )
    limit = state.settings.max_body_bytes
    try:
        return RequestSegment(directory, name, int(length), limit, room)
    except SegmentTooLarge:
        raise PayloadTooLarge(
            f"the request body is larger than the limit of {limit} bytes (ROBODYN_MAX_BODY_BYTES)"
        ) from None
    except SegmentError as exc:
        raise InvalidInput(str(exc)) from None


class AnswerWriter:
    """The encoder of binary answers to a body in shared memory: writes the answer into the
    segment's answer file and returns an empty body."""

    def __init__(self, segment: RequestSegment) -> None:
        self.segment = segment

    def __call__(self, values: Mapping[str, Any]) -> bytes:
        """Write the answer `values`; `Overloaded` (503, retried by clients) when the memory
        file system of the segment directory has no room for it."""
        try:
            self.segment.write_answer(binary.encode_parts(values))
        except OSError as exc:
            if exc.errno not in _NO_ROOM:
                raise
            raise Overloaded(
                "the shared-memory directory has no room for the answer now (its memory file "
                "system is full); retry shortly, or send smaller batches"
            ) from None
        return b""

    def header_only(self, values: Mapping[str, Any]) -> bool:
        """Whether the answer `values` was computed into the answer file
        (`RequestSegment.answer_arrays`), so that writing it is writing its header: quick
        enough for the event loop, where a thread hop there and back costs more (0.2–0.3 ms
        on a 2-core machine)."""
        arrays = [v for v in values.values() if isinstance(v, np.ndarray)]
        return len(arrays) == len(values) and self.segment.holds_answer(arrays)


async def sweep_periodically(directory: SegmentDirectory) -> None:
    """Remove the segments of clients that are gone, every `SWEEP_INTERVAL_S` (a task of
    the app's lifespan)."""
    while True:
        await asyncio.sleep(SWEEP_INTERVAL_S)
        try:
            directory.sweep()
        except OSError as exc:
            log.warning("sweeping the shared-memory segments failed: %s", exc)
