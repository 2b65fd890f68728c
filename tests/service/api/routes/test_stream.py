"""The WebSocket stream: each message answered in order as its HTTP endpoint answers it."""

from __future__ import annotations

import numpy as np
import orjson
import pytest
from starlette.testclient import WebSocketDenialResponse

from tests.helpers import random_state, record_off_loop
from tests.service.api.encoding.test_binary import decode_answer, encode_request


def test_stream_answers_equal_http_answers_in_order(api, catalog_registry):
    model = catalog_registry.catalog["ur5"].model
    rng = np.random.default_rng(11)
    messages = []
    for i in range(20):
        q, v, a = (x.tolist() for x in random_state(model, rng))
        quantity = [
            "mass-matrix",
            "gravity",
            "coriolis",
            "nonlinear-effects",
            "inverse-dynamics",
            "forward-dynamics",
        ][i % 6]
        body = {"q": q, "v": v, "a": a, "tau": a}
        keep = {
            "mass-matrix": "q",
            "gravity": "q",
            "coriolis": "qv",
            "nonlinear-effects": "qv",
            "inverse-dynamics": "qva",
            "forward-dynamics": "qvt",
        }[quantity]
        names = {"q": "q", "v": "v", "a": "a", "t": "tau"}
        messages.append((quantity, {names[c]: body[names[c]] for c in keep}))
    with api.websocket_connect("/v1/robots/ur5/stream") as ws:
        for quantity, body in messages:  # all sent first: answers must come back in order
            ws.send_text(orjson.dumps({"quantity": quantity, **body}).decode())
        for quantity, body in messages:
            expected = api.post(f"/v1/robots/ur5/{quantity}", json=body).json()
            assert ws.receive_json() == expected


def test_stream_errors_are_problems_and_the_stream_stays_open(api):
    with api.websocket_connect("/v1/robots/ur5/stream") as ws:
        for message, code, needle in [
            ("not json", "validation_error", "not valid JSON"),
            ("[1, 2]", "validation_error", "JSON object"),
            ('{"quantity": "jerk", "q": [0,0,0,0,0,0]}', "validation_error", "inverse-dynamics"),
            ('{"quantity": "gravity", "q": [0,0,0,0,0]}', "dimension_mismatch", "nq = 6"),
            ('{"quantity": "gravity", "q": [0,0,0,0,0,0], "x": 1}', "validation_error", "x"),
        ]:
            ws.send_text(message)
            problem = ws.receive_json()
            assert problem["code"] == code and needle in problem["detail"], problem
            assert problem["status"] == 422
        ws.send_text('{"quantity": "gravity", "q": [0,0,0,0,0,0]}')
        assert len(ws.receive_json()["gravity"]) == 6


def test_stream_binary_messages(api, catalog_registry):
    model = catalog_registry.catalog["talos"].model
    rng = np.random.default_rng(2)
    q, v, a = (
        np.stack(x) for x in zip(*[random_state(model, rng) for _ in range(70)], strict=True)
    )
    expected = api.post(
        "/v1/robots/talos/inverse-dynamics",
        json={"q": q.tolist(), "v": v.tolist(), "a": a.tolist()},
    ).json()["tau"]
    with api.websocket_connect("/v1/robots/talos/stream") as ws:
        ws.send_bytes(encode_request({"q": q, "v": v, "a": a}, {"quantity": "inverse-dynamics"}))
        got = decode_answer(ws.receive_bytes())["tau"]
        np.testing.assert_array_equal(got, expected)
        ws.send_bytes(b"\x10\0\0\0\0\0\0\0junk")
        assert ws.receive_json()["code"] == "validation_error"
        ws.send_bytes(encode_request({"q": q}, {"quantity": "mass-matrix", "frame": "x"}))
        assert ws.receive_json()["code"] == "validation_error"


def test_stream_of_an_unknown_robot_is_refused_with_a_404_problem(api):
    with (
        pytest.raises(WebSocketDenialResponse) as refused,
        api.websocket_connect("/v1/robots/no_such_robot/stream"),
    ):
        pass
    assert refused.value.status_code == 404
    assert refused.value.headers["content-type"].startswith("application/problem+json")
    assert refused.value.json()["code"] == "robot_not_found"


def test_large_stream_messages_are_parsed_and_computed_off_the_event_loop(api, monkeypatch):
    """A big JSON message on the stream is parsed, computed and encoded in worker threads, like
    a big HTTP body; the answer equals the HTTP one."""
    from service.api.routes import stream as stream_module

    calls = record_off_loop(monkeypatch, stream_module)
    q = np.random.default_rng(9).uniform(-1, 1, (900, 6))
    with api.websocket_connect("/v1/robots/ur5/stream") as ws:
        ws.send_text(orjson.dumps({"quantity": "gravity", "q": q.tolist()}).decode())
        answer = orjson.loads(ws.receive_text())
    assert calls == ["_parse_text", "json_bytes"]
    want = api.post("/v1/robots/ur5/gravity", json={"q": q.tolist()}).json()
    np.testing.assert_array_equal(np.array(answer["gravity"]), np.array(want["gravity"]))
