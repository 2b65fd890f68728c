"""How the dynamics fast path reads a request body (service/api/fast_path._body): whole from
one message; from several, into one buffer of the Content-Length as it arrives, or joined
when no length was announced; never more than announced; a disconnect ends it."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest
from starlette.requests import ClientDisconnect

from service.api.middleware.fast_path import _body
from service.errors import InvalidInput

PARTS = [b"abc", b"", b"defgh", b"ij"]


def _read(
    parts: list[bytes], headers: list[tuple[bytes, bytes]], disconnect_after: int | None = None
) -> Any:
    messages: list[dict[str, Any]] = [
        {"type": "http.request", "body": p, "more_body": i < len(parts) - 1}
        for i, p in enumerate(parts)
    ]
    if disconnect_after is not None:
        messages = [*messages[:disconnect_after], {"type": "http.disconnect"}]
    it = iter(messages)

    async def receive() -> dict[str, Any]:
        return next(it)

    return asyncio.run(_body({"headers": headers}, receive))


def test_one_message_is_the_body_itself() -> None:
    assert _read([b"whole"], []) == b"whole"


def test_several_messages_fill_one_buffer_of_the_announced_length() -> None:
    body = _read(PARTS, [(b"content-length", b"10")])
    assert body == b"abcdefghij" and isinstance(body, bytearray)


def test_without_a_length_the_messages_are_joined() -> None:
    assert _read(PARTS, []) == b"abcdefghij"
    assert _read(PARTS, [(b"content-length", b"x")]) == b"abcdefghij"


def test_more_than_announced_is_refused() -> None:
    with pytest.raises(InvalidInput, match="longer than its Content-Length 6"):
        _read(PARTS, [(b"content-length", b"6")])


def test_a_disconnect_ends_the_body() -> None:
    with pytest.raises(ClientDisconnect):
        _read(PARTS, [(b"content-length", b"10")], disconnect_after=2)
