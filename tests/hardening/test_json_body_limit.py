"""JSON bodies are kept to a size the event loop can parse (ROBODYN_MAX_JSON_BODY_BYTES):
a larger JSON batch is a 413 that points to the binary form, which carries the same batch up
to ROBODYN_MAX_BODY_BYTES; uploads keep their own limit. On a real server, /health/live stays
fast while the largest admitted JSON batch is parsed and computed."""

from __future__ import annotations

from collections.abc import Iterator

import httpx
import numpy as np
import orjson
import pytest

from service.api.encoding.binary import BINARY_MEDIA_TYPE, encode
from tests.hardening.health_probe import health_latencies_during
from tests.servers import running_server

LIMIT = 4096


def _ur5_q(n: int) -> np.ndarray:
    return np.random.default_rng(3).uniform(-1, 1, (n, 6))


def test_a_json_batch_over_the_json_limit_is_a_413_pointing_to_the_binary_form(app_factory):
    client = app_factory(catalog="ur5", max_json_body_bytes=LIMIT)
    q = _ur5_q(200)  # about 23 kB of JSON
    body = orjson.dumps({"q": q.tolist()})
    assert len(body) > LIMIT
    r = client.post(
        "/v1/robots/ur5/gravity", content=body, headers={"content-type": "application/json"}
    )
    assert r.status_code == 413, r.text
    problem = r.json()
    assert problem["code"] == "payload_too_large"
    assert "ROBODYN_MAX_JSON_BODY_BYTES" in problem["detail"]
    assert BINARY_MEDIA_TYPE in problem["detail"]
    # the same batch in the binary form is answered, and equals the JSON answer of a part
    binary = client.post(
        "/v1/robots/ur5/gravity",
        content=encode({"q": q}),
        headers={"content-type": BINARY_MEDIA_TYPE, "accept": "application/json"},
    )
    assert binary.status_code == 200, binary.text
    small = client.post("/v1/robots/ur5/gravity", json={"q": q[:20].tolist()})
    assert small.status_code == 200
    np.testing.assert_array_equal(np.array(binary.json()["gravity"])[:20], small.json()["gravity"])


def test_uploads_keep_their_own_limit(app_factory):
    client = app_factory(catalog="ur5", max_json_body_bytes=LIMIT)
    padding = " " * (2 * LIMIT)
    urdf = (
        f'<robot name="p">{padding}<link name="a"/><link name="b"><inertial><mass value="1"/>'
        '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>'
        '<joint name="j" type="continuous"><parent link="a"/><child link="b"/></joint>'
        "</robot>"
    )
    r = client.post("/v1/robots", json={"urdf": urdf})
    assert r.status_code == 201, r.text


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    with running_server(tmp_path_factory.mktemp("json-limit"), catalog="talos") as url:
        yield url


@pytest.mark.slow  # a latency bound: with the other /health/live probes in the slow suite
def test_health_stays_fast_while_the_largest_json_batch_is_handled(base: str) -> None:
    limit = 16 * 1024 * 1024  # the default ROBODYN_MAX_JSON_BODY_BYTES
    rng = np.random.default_rng(0)
    q = rng.normal(0, 0.3, (60_000, 39))
    q[:, 3:7] = [0.0, 0.0, 0.0, 1.0]
    text = orjson.dumps({"q": q.tolist()})  # full precision: about 20 bytes a number
    states = int(60_000 * (limit - 100) / len(text))
    body = orjson.dumps({"q": q[:states].tolist()})
    assert limit - 200_000 < len(body) <= limit

    def post() -> httpx.Response:
        return httpx.post(
            base + "/v1/robots/talos/gravity",
            content=body,
            timeout=300,
            headers={"content-type": "application/json"},
        )

    r, latencies = health_latencies_during(base, post)
    assert r.status_code == 200, r.text[:300]
    assert len(latencies) > 20
    assert np.percentile(latencies, 99) < 0.25, sorted(latencies)[-5:]
    assert max(latencies) < 0.5, sorted(latencies)[-5:]


def test_a_body_one_byte_over_the_default_json_limit_is_a_413(base: str) -> None:
    limit = 16 * 1024 * 1024  # the default ROBODYN_MAX_JSON_BODY_BYTES
    body = orjson.dumps({"q": [0.0] * 39})
    over = httpx.post(
        base + "/v1/robots/talos/gravity",
        content=body + b" " * (limit - len(body) + 1),
        headers={"content-type": "application/json"},
        timeout=60,
    )
    assert over.status_code == 413 and "ROBODYN_MAX_JSON_BODY_BYTES" in over.json()["detail"]
