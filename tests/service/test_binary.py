"""The binary form of dynamics requests and answers: bit for bit the JSON form, and its errors."""

from __future__ import annotations

import struct

import numpy as np
import orjson
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from service.api import binary
from service.errors import InvalidInput
from tests.helpers import random_state

BIN = binary.BINARY_MEDIA_TYPE
INPUTS = {"mass-matrix": ("q",), "gravity": ("q",), "coriolis": ("q", "v"),
          "nonlinear-effects": ("q", "v"), "inverse-dynamics": ("q", "v", "a"),
          "forward-dynamics": ("q", "v", "tau")}


def encode_request(arrays: dict[str, np.ndarray], fields: dict | None = None) -> bytes:
    """Written from the format description (docs/binary-format.md), not with the server's
    encoder, so that the two are checked against each other."""
    descriptors, chunks, offset = {}, [], 0
    for name, value in arrays.items():
        a = np.ascontiguousarray(value, dtype="<f8")
        descriptors[name] = {"shape": list(a.shape), "offset": offset}
        chunks.append(a.tobytes())
        offset += a.nbytes
    header = orjson.dumps({"fields": fields or {}, "arrays": descriptors})
    pad = b"\0" * ((8 - (8 + len(header)) % 8) % 8)
    return b"RDY1" + struct.pack("<I", len(header)) + header + pad + b"".join(chunks)


def decode_answer(content: bytes) -> dict[str, np.ndarray]:
    assert content[:4] == b"RDY1"
    (size,) = struct.unpack("<I", content[4:8])
    header = orjson.loads(content[8:8 + size])
    start = 8 + size + (-(8 + size) % 8)
    out = dict(header["fields"])
    for name, d in header["arrays"].items():
        count = int(np.prod(d["shape"]))
        at = start + d["offset"]
        out[name] = np.frombuffer(content[at:at + 8 * count], "<f8").reshape(d["shape"])
    return out


def states(model, n: int, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    q, v, a = (np.stack(x) for x in zip(*[random_state(model, rng) for _ in range(n)],
                                         strict=True))
    return {"q": q, "v": v, "a": a, "tau": a * 10.0}


@pytest.mark.parametrize("robot", ["ur5", "talos"])
@pytest.mark.parametrize("quantity", list(INPUTS))
@pytest.mark.parametrize("n", [1, 100])
def test_binary_answers_equal_json_answers_bit_for_bit(api, catalog_registry, robot, quantity,
                                                       n):
    model = catalog_registry.catalog[robot].model
    arrays = {k: v for k, v in states(model, n).items() if k in INPUTS[quantity]}
    if n == 1:
        arrays = {k: v[0] for k, v in arrays.items()}  # 1-D: one state
    path = f"/v1/robots/{robot}/{quantity}"
    as_json = api.post(path, json={k: v.tolist() for k, v in arrays.items()})
    as_binary = api.post(path, content=encode_request(arrays),
                         headers={"content-type": BIN, "accept": BIN})
    assert as_json.status_code == as_binary.status_code == 200, as_binary.text
    assert as_binary.headers["content-type"] == BIN
    expected, got = as_json.json(), decode_answer(as_binary.content)
    assert set(expected) == set(got)
    for key, value in expected.items():
        np.testing.assert_array_equal(got[key], np.asarray(value))
        assert got[key].shape == np.asarray(value).shape


def test_binary_request_json_answer_and_json_request_binary_answer(api):
    q = np.array([0.1, -1.2, 1.3, 0.2, 0.5, -0.3])
    reference = api.post("/v1/robots/ur5/gravity", json={"q": q.tolist()}).json()
    r = api.post("/v1/robots/ur5/gravity", content=encode_request({"q": q}),
                 headers={"content-type": BIN})
    assert r.headers["content-type"] == "application/json"
    assert r.json() == reference
    r = api.post("/v1/robots/ur5/gravity", json={"q": q.tolist()}, headers={"accept": BIN})
    np.testing.assert_array_equal(decode_answer(r.content)["gravity"], reference["gravity"])


def test_large_forward_dynamics_batch_is_bit_identical_to_single_states(api, catalog_registry):
    """Large batches use Pinocchio's OpenMP ABA; it must agree with the per-state answers."""
    model = catalog_registry.catalog["talos"].model
    s = states(model, 300, seed=5)
    body = encode_request({"q": s["q"], "v": s["v"], "tau": s["tau"]})
    r = api.post("/v1/robots/talos/forward-dynamics", content=body,
                 headers={"content-type": BIN, "accept": BIN})
    a = decode_answer(r.content)["a"]
    for i in (0, 150, 299):
        single = api.post("/v1/robots/talos/forward-dynamics",
                          json={"q": s["q"][i].tolist(), "v": s["v"][i].tolist(),
                                "tau": s["tau"][i].tolist()}).json()["a"]
        np.testing.assert_array_equal(a[i], single)
    data = model.createData()
    expected = pin.aba(model, data, s["q"][7], s["v"][7], s["tau"][7])
    np.testing.assert_allclose(a[7], expected, rtol=1e-9, atol=1e-9)


def _problem(r, code: str) -> str:
    assert r.status_code == 422, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    body = r.json()
    assert body["code"] == code
    return body["detail"]


GOOD = {"q": np.zeros(6)}


@pytest.mark.parametrize(("content", "needle"), [
    (b"", "prefix"),
    (b"XXXX" + struct.pack("<I", 2) + b"{}", "RDY1"),
    (b"RDY1" + struct.pack("<I", 10_000) + b"{}", "runs past"),
    (b"RDY1" + struct.pack("<I", 3) + b"{x}", "not valid JSON"),
    (b"RDY1" + struct.pack("<I", 2) + b"[]", "object"),
    (encode_request(GOOD)[:-8], "runs past"),
    (encode_request({"q": np.zeros(6), "v": np.zeros(6)}), "unknown array 'v'"),
    (encode_request({}), "missing array 'q'"),
])
def test_malformed_binary_bodies_are_422_naming_the_fault(api, content, needle):
    r = api.post("/v1/robots/ur5/mass-matrix", content=content, headers={"content-type": BIN})
    assert needle in _problem(r, "validation_error")


def test_binary_inputs_get_the_same_checks_as_json(api, catalog_registry):
    bad = np.zeros(6)
    bad[2] = np.nan
    r = api.post("/v1/robots/ur5/mass-matrix", content=encode_request({"q": bad}),
                 headers={"content-type": BIN})
    assert "non-finite" in _problem(r, "validation_error")
    r = api.post("/v1/robots/ur5/mass-matrix", content=encode_request({"q": np.zeros(5)}),
                 headers={"content-type": BIN})
    assert "nq = 6" in _problem(r, "dimension_mismatch")
    r = api.post("/v1/robots/ur5/mass-matrix",
                 content=encode_request(GOOD, {"frame": "tool0"}),
                 headers={"content-type": BIN})
    assert "frame" in _problem(r, "validation_error")
    nq = catalog_registry.catalog["talos"].nq
    r = api.post("/v1/robots/talos/gravity", content=encode_request({"q": np.zeros(nq)}),
                 headers={"content-type": BIN})  # a zero quaternion
    assert "unit norm" in _problem(r, "invalid_configuration")


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=200) | st.builds(lambda tail: b"RDY1" + tail, st.binary(max_size=200)))
def test_decoder_refuses_arbitrary_bytes_cleanly(content):
    try:
        fields, arrays = binary.decode(content)
    except InvalidInput as exc:
        assert "binary body" in exc.detail
    else:
        assert isinstance(fields, dict) and all(a.dtype == np.float64 for a in arrays.values())


def test_encoder_round_trips_through_the_reference_decoder():
    values = {"m": np.arange(24.0).reshape(2, 3, 4), "s": np.float64(2.5) * np.ones(()),
              "label": "x"}
    out = decode_answer(binary.encode(values))
    np.testing.assert_array_equal(out["m"], values["m"])
    assert out["s"].shape == () and float(out["s"]) == 2.5 and out["label"] == "x"


def test_openapi_documents_the_dynamics_routes_and_the_binary_form(api):
    doc = api.get("/openapi.json").json()
    for quantity in INPUTS:
        op = doc["paths"][f"/v1/robots/{{robot_id}}/{quantity}"]["post"]
        assert "requestBody" in op and "200" in op["responses"]
        assert op["x-binary-media-type"] == BIN
        assert "binary" in op["description"]
