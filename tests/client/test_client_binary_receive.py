"""How the clients read binary answers: a successful one with a Content-Length goes straight
into one preallocated buffer (`core.Receiver`); anything else (content-coded, no length, an
error) through httpx's own reading. Both give the same, writable arrays."""

from __future__ import annotations

import asyncio
import gzip
from collections.abc import Callable

import httpx
import numpy as np
import pytest
from robodyn import AsyncClient, Client, ResponseFormatError, binary
from robodyn.answer_memory import AnswerMemory

MASS = np.arange(2 * 3 * 3, dtype=float).reshape(2, 3, 3) / 7.0  # any float64 bits


def _answer(transform: Callable[[bytes], tuple[bytes, dict[str, str]]]) -> httpx.MockTransport:
    def handler(request: httpx.Request) -> httpx.Response:
        assert request.headers["accept"].startswith(binary.MEDIA_TYPE)
        content, headers = transform(binary.encode({"mass_matrix": MASS}))
        return httpx.Response(
            200,
            headers={"content-type": binary.MEDIA_TYPE, **headers},
            stream=httpx.ByteStream(content),
        )

    return httpx.MockTransport(handler)


def _plain(body: bytes) -> tuple[bytes, dict[str, str]]:
    return body, {"content-length": str(len(body))}


def _gzipped(body: bytes) -> tuple[bytes, dict[str, str]]:
    packed = gzip.compress(body)
    return packed, {"content-length": str(len(packed)), "content-encoding": "gzip"}


def _no_length(body: bytes) -> tuple[bytes, dict[str, str]]:
    return body, {}


def _truncated(body: bytes) -> tuple[bytes, dict[str, str]]:
    return body[:-8], {"content-length": str(len(body))}


def _mass_matrix_sync(transport: httpx.MockTransport) -> np.ndarray:
    with (
        httpx.Client(transport=transport, base_url="http://robodyn") as http,
        Client(http_client=http, binary=True) as client,
    ):
        return client.mass_matrix("ur5", np.zeros((2, 6)))


def _mass_matrix_async(transport: httpx.MockTransport) -> np.ndarray:
    async def run() -> np.ndarray:
        async with (
            httpx.AsyncClient(transport=transport, base_url="http://robodyn") as http,
            AsyncClient(http_client=http, binary=True) as client,
        ):
            return await client.mass_matrix("ur5", np.zeros((2, 6)))

    return asyncio.run(run())


CLIENTS = [_mass_matrix_sync, _mass_matrix_async]


@pytest.mark.parametrize("call", CLIENTS)
@pytest.mark.parametrize("form", [_plain, _gzipped, _no_length])
def test_every_form_of_binary_answer_decodes_bit_for_bit(call, form) -> None:
    got = call(_answer(form))
    np.testing.assert_array_equal(got, MASS)
    got[0, 0, 0] = 1.0  # the caller owns a writable array
    assert got.flags.writeable


@pytest.mark.parametrize("call", CLIENTS)
def test_an_answer_shorter_than_its_content_length_is_a_format_error(call) -> None:
    with pytest.raises(ResponseFormatError, match="ended after"):
        call(_answer(_truncated))


def test_the_receiver_refuses_more_bytes_than_announced() -> None:
    from robodyn import core

    receiver = core.Receiver(httpx.Response(200), 4, AnswerMemory())
    receiver.add(b"ab")
    with pytest.raises(ResponseFormatError, match="longer than its Content-Length 4"):
        receiver.add(b"cde")


def test_only_plain_successful_binary_answers_use_the_buffer() -> None:
    from robodyn import core

    def response(status: int = 200, **headers: str) -> httpx.Response:
        return httpx.Response(
            status, headers={"content-type": binary.MEDIA_TYPE, "content-length": "80", **headers}
        )

    assert core.binary_length(response()) == 80
    assert core.binary_length(response(422)) is None
    assert core.binary_length(response(**{"content-encoding": "gzip"})) is None
    assert core.binary_length(response(**{"content-length": "-1"})) is None
    assert core.binary_length(response(**{"content-type": "application/json"})) is None
