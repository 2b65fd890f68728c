"""Content negotiation by `Accept` qualities: the form named with the highest q answers, q=0
refuses a form, wildcards never outrank a form named explicitly (RFC 9110 §12.5.1)."""

from __future__ import annotations

import numpy as np
import pytest
from safetensors.numpy import load

from service.api.encoding.accept import prefers, qualities
from service.api.encoding.binary import BINARY_MEDIA_TYPE
from service.api.progress import PROGRESS_MEDIA_TYPE

STREAM, BINARY = PROGRESS_MEDIA_TYPE, BINARY_MEDIA_TYPE


def test_qualities_read_q_with_spaces_case_and_bad_values() -> None:
    got = qualities("Application/JSON;q=0.5, application/x-ndjson ; Q = 0.25, */*;q=oops, a/b;q=7")
    # parameter names are case-insensitive; an unreadable q is 1, a q over 1 is 1
    assert got == {"application/json": 0.5, STREAM: 0.25, "*/*": 1.0, "a/b": 1.0}


@pytest.mark.parametrize(
    ("accept", "form"),
    [
        ("", "json"),
        ("*/*", "json"),
        (STREAM, "stream"),
        (BINARY, "binary"),
        (f"{BINARY};q=1, {STREAM};q=0.5", "binary"),
        (f"{BINARY};q=0.5, {STREAM};q=1", "stream"),
        (f"{BINARY}, {STREAM}", "stream"),  # a tie: the stream (whose answer is JSON)
        (f"{STREAM};q=0, application/json", "json"),
        (f"{STREAM};q=0.000", "json"),
        (f"application/json, {STREAM};q=0.5", "json"),
        (f"application/json;q=0.5, {STREAM};q=0.9", "stream"),
        (f"*/*;q=1, {STREAM};q=0.1", "stream"),
        (f"{BINARY};q=0, */*", "json"),
    ],
)
def test_the_highest_named_quality_wins(accept: str, form: str) -> None:
    """The routes ask for the stream first, then for the binary form; JSON otherwise."""
    chosen = (
        "stream"
        if prefers(accept, STREAM, BINARY)
        else "binary"
        if prefers(accept, BINARY)
        else "json"
    )
    assert chosen == form


def test_a_route_answers_the_preferred_form(api) -> None:
    """Over HTTP: safetensors preferred to the stream is the binary answer; the reverse, the
    stream; JSON preferred to both, JSON."""
    body = {"q": [0.1] * 6}
    plain = np.array(api.post("/v1/robots/ur5/gravity", json=body).json()["gravity"])
    binary = api.post(
        "/v1/robots/ur5/gravity", json=body, headers={"Accept": f"{BINARY};q=1, {STREAM};q=0.5"}
    )
    assert binary.headers["content-type"] == BINARY
    np.testing.assert_array_equal(load(binary.content)["gravity"], plain)
    stream = api.post(
        "/v1/robots/ur5/gravity", json=body, headers={"Accept": f"{BINARY};q=0.5, {STREAM}"}
    )
    assert stream.headers["content-type"].startswith(STREAM)
    json = api.post(
        "/v1/robots/ur5/gravity",
        json=body,
        headers={"Accept": f"application/json, {BINARY};q=0.9, {STREAM};q=0.8"},
    )
    assert json.headers["content-type"] == "application/json"
    np.testing.assert_array_equal(np.array(json.json()["gravity"]), plain)
