"""The binary form of dynamics requests and answers: bit for bit the JSON form, and its errors."""

from __future__ import annotations

import shutil
import struct
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import orjson
import pinocchio as pin
import pytest
import safetensors
import safetensors.numpy
from hypothesis import given, settings
from hypothesis import strategies as st

from service.api.encoding import binary
from service.errors import InvalidInput
from tests.helpers import random_state

BIN = binary.BINARY_MEDIA_TYPE
INPUTS = {
    "mass-matrix": ("q",),
    "gravity": ("q",),
    "coriolis": ("q", "v"),
    "nonlinear-effects": ("q", "v"),
    "inverse-dynamics": ("q", "v", "a"),
    "forward-dynamics": ("q", "v", "tau"),
}


def encode_request(arrays: dict[str, np.ndarray], fields: dict | None = None) -> bytes:
    """Written from the format description (docs/binary-format.md), not with the server's
    encoder, so that the two are checked against each other."""
    header, chunks, offset = {}, [], 0
    if fields:
        header["__metadata__"] = {k: orjson.dumps(v).decode() for k, v in fields.items()}
    for name, value in arrays.items():
        a = np.ascontiguousarray(value, dtype="<f8")
        header[name] = {
            "dtype": "F64",
            "shape": list(a.shape),
            "data_offsets": [offset, offset + a.nbytes],
        }
        chunks.append(a.tobytes())
        offset += a.nbytes
    text = orjson.dumps(header)
    text += b" " * (-len(text) % 8)
    return struct.pack("<Q", len(text)) + text + b"".join(chunks)


def decode_answer(content: bytes) -> dict[str, np.ndarray]:
    """Read with the `safetensors` library itself: the answer is a valid safetensors file."""
    out: dict = safetensors.numpy.load(bytes(content))
    with tempfile.NamedTemporaryFile(suffix=".safetensors") as f:
        f.write(content)
        f.flush()
        with safetensors.safe_open(f.name, framework="numpy") as opened:
            metadata = opened.metadata() or {}
    out.update({k: orjson.loads(v) for k, v in metadata.items()})
    return out


def raw(header: dict, data: bytes = b"") -> bytes:
    text = orjson.dumps(header)
    return struct.pack("<Q", len(text)) + text + data


def raw_json(text: bytes, data: bytes) -> bytes:
    return struct.pack("<Q", len(text)) + text + data


def states(model, n: int, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    q, v, a = (np.stack(x) for x in zip(*[random_state(model, rng) for _ in range(n)], strict=True))
    return {"q": q, "v": v, "a": a, "tau": a * 10.0}


@pytest.mark.parametrize("robot", ["ur5", "talos"])
@pytest.mark.parametrize("quantity", list(INPUTS))
@pytest.mark.parametrize("n", [1, 100])
def test_binary_answers_equal_json_answers_bit_for_bit(api, catalog_registry, robot, quantity, n):
    model = catalog_registry.catalog[robot].model
    arrays = {k: v for k, v in states(model, n).items() if k in INPUTS[quantity]}
    if n == 1:
        arrays = {k: v[0] for k, v in arrays.items()}  # 1-D: one state
    path = f"/v1/robots/{robot}/{quantity}"
    as_json = api.post(path, json={k: v.tolist() for k, v in arrays.items()})
    as_binary = api.post(
        path, content=encode_request(arrays), headers={"content-type": BIN, "accept": BIN}
    )
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
    r = api.post(
        "/v1/robots/ur5/gravity", content=encode_request({"q": q}), headers={"content-type": BIN}
    )
    assert r.headers["content-type"] == "application/json"
    assert r.json() == reference
    r = api.post("/v1/robots/ur5/gravity", json={"q": q.tolist()}, headers={"accept": BIN})
    np.testing.assert_array_equal(decode_answer(r.content)["gravity"], reference["gravity"])


def test_large_forward_dynamics_batch_is_bit_identical_to_single_states(api, catalog_registry):
    """Large batches use Pinocchio's OpenMP ABA; it must agree with the per-state answers."""
    model = catalog_registry.catalog["talos"].model
    s = states(model, 300, seed=5)
    body = encode_request({"q": s["q"], "v": s["v"], "tau": s["tau"]})
    r = api.post(
        "/v1/robots/talos/forward-dynamics",
        content=body,
        headers={"content-type": BIN, "accept": BIN},
    )
    a = decode_answer(r.content)["a"]
    for i in (0, 150, 299):
        single = api.post(
            "/v1/robots/talos/forward-dynamics",
            json={"q": s["q"][i].tolist(), "v": s["v"][i].tolist(), "tau": s["tau"][i].tolist()},
        ).json()["a"]
        np.testing.assert_array_equal(a[i], single)
    data = model.createData()
    expected = pin.aba(model, data, s["q"][7], s["v"][7], s["tau"][7])
    np.testing.assert_allclose(a[7], expected, rtol=1e-9, atol=1e-9)


GOOD = {"q": np.zeros(6)}


def _problem(r, code: str) -> str:
    assert r.status_code == 422, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    body = r.json()
    assert body["code"] == code
    return body["detail"]


F64_6 = {"dtype": "F64", "shape": [6], "data_offsets": [0, 48]}


@pytest.mark.parametrize(
    ("content", "needle"),
    [
        (b"", "8-byte"),
        (b"RDY1" + struct.pack("<I", 2) + b"{}", "over the cap"),  # the former format
        (struct.pack("<Q", 10_000) + b"{}", "runs past"),
        # a header over the 1 MiB cap is named as such, whether or not the body holds it
        (struct.pack("<Q", (1 << 20) + 8) + b"{}", "over the cap of 1048576 bytes"),
        (struct.pack("<Q", (1 << 20) + 8) + b" " * ((1 << 20) + 64), "over the cap of 1048576"),
        # a name given twice (JSON parsers keep the last silently)
        (
            raw_json(
                b'{"q":' + orjson.dumps(F64_6) + b',"q":' + orjson.dumps(F64_6) + b"}", bytes(48)
            ),
            "'q' is given twice",
        ),
        (
            raw_json(
                b'{"q":{"dtype":"F64","dtype":"F64","shape":[6],"data_offsets":[0,48]}}', bytes(48)
            ),
            "'dtype' is given twice",
        ),
        (
            raw_json(
                b'{"__metadata__":{"frame":"\\"a\\"","frame":"\\"b\\""},"q":'
                + orjson.dumps(F64_6)
                + b"}",
                bytes(48),
            ),
            "'frame' is given twice",
        ),
        (struct.pack("<Q", 3) + b"{x}", "not valid JSON"),
        (struct.pack("<Q", 2) + b"[]", "JSON object"),
        (raw({"__metadata__": {"frame": 3}, "q": F64_6}, bytes(48)), "__metadata__"),
        (raw({"__metadata__": {"frame": "tool0"}, "q": F64_6}, bytes(48)), "not a JSON text"),
        (raw({"q": {**F64_6, "dtype": "F32"}}, bytes(48)), "dtype"),
        (raw({"q": {"dtype": "F64", "shape": [6]}}, bytes(48)), "data_offsets"),
        (raw({"q": {**F64_6, "shape": [-6]}}, bytes(48)), "non-negative"),
        (raw({"q": {**F64_6, "shape": [6.0]}}, bytes(48)), "non-negative"),
        (raw({"q": {**F64_6, "shape": [1, 1, 1, 6]}}, bytes(48)), "at most 3"),
        (raw({"q": {**F64_6, "shape": [0, 2**63]}}, bytes(48)), "non-negative"),
        (raw({"q": {**F64_6, "shape": [2**40, 2**40]}}, bytes(48)), "non-negative"),
        (raw({"q": {**F64_6, "shape": [6, 6, 6]}}, bytes(48)), "carries 6"),
        (raw({"q": {**F64_6, "data_offsets": [8, 56]}}, bytes(56)), "must start where"),
        (raw({"q": {**F64_6, "data_offsets": [0, 40]}}, bytes(48)), "must start where"),
        (raw({"q": F64_6}, bytes(56)), "end at byte 48"),
        (raw({"q": F64_6, "v": {**F64_6, "data_offsets": [0, 48]}}, bytes(96)), "must start where"),
        (raw({"q": F64_6, "__metadata__": {"q": "1"}}, bytes(48)), "both"),
        (encode_request(GOOD)[:-8], "the body carries 5"),
        (encode_request({"q": np.zeros(6), "v": np.zeros(6)}), "unknown array 'v'"),
        (encode_request({}), "missing array 'q'"),
    ],
)
def test_malformed_binary_bodies_are_422_naming_the_fault(api, content, needle):
    r = api.post("/v1/robots/ur5/mass-matrix", content=content, headers={"content-type": BIN})
    assert needle in _problem(r, "validation_error")


def test_binary_inputs_get_the_same_checks_as_json(api, catalog_registry):
    bad = np.zeros(6)
    bad[2] = np.nan
    r = api.post(
        "/v1/robots/ur5/mass-matrix",
        content=encode_request({"q": bad}),
        headers={"content-type": BIN},
    )
    assert "non-finite" in _problem(r, "validation_error")
    r = api.post(
        "/v1/robots/ur5/mass-matrix",
        content=encode_request({"q": np.zeros(5)}),
        headers={"content-type": BIN},
    )
    assert "nq = 6" in _problem(r, "dimension_mismatch")
    r = api.post(
        "/v1/robots/ur5/mass-matrix",
        content=encode_request(GOOD, {"frame": "tool0"}),
        headers={"content-type": BIN},
    )
    assert "frame" in _problem(r, "validation_error")
    nq = catalog_registry.catalog["talos"].nq
    r = api.post(
        "/v1/robots/talos/gravity",
        content=encode_request({"q": np.zeros(nq)}),
        headers={"content-type": BIN},
    )  # a zero quaternion
    assert "unit norm" in _problem(r, "invalid_configuration")


@settings(max_examples=300, deadline=None)
@given(
    st.binary(max_size=200)
    | st.builds(
        lambda n, tail: struct.pack("<Q", n) + tail, st.integers(0, 300), st.binary(max_size=200)
    )
)
def test_decoder_refuses_arbitrary_bytes_cleanly(content):
    try:
        fields, arrays = binary.decode(content)
    except InvalidInput as exc:
        assert "binary body" in exc.detail
    else:
        assert isinstance(fields, dict) and all(a.dtype == np.float64 for a in arrays.values())


@settings(max_examples=400, deadline=None)
@given(
    shape=st.lists(st.integers(-2, 2**70), max_size=4),
    offsets=st.lists(st.integers(-8, 2**70), max_size=3),
    dtype=st.sampled_from(["F64", "F32", "I64", 3]),
    data=st.integers(0, 80),
    metadata=st.dictionaries(st.text(max_size=3), st.text(max_size=5) | st.integers(), max_size=2),
)
def test_decoder_refuses_hostile_headers_cleanly(shape, offsets, dtype, data, metadata):
    """Any header: a `binary body` InvalidInput, or float64 arrays that fit the body."""
    import json

    header = {
        "__metadata__": metadata,
        "q": {"dtype": dtype, "shape": shape, "data_offsets": offsets},
    }
    content = raw_json(json.dumps(header).encode(), bytes(data))
    try:
        _, arrays = binary.decode(content)
    except InvalidInput as exc:
        assert "binary body" in exc.detail
    else:
        assert arrays["q"].dtype == np.float64 and arrays["q"].nbytes == data


def test_encoder_round_trips_through_the_reference_decoder():
    values = {
        "m": np.arange(24.0).reshape(2, 3, 4),
        "s": np.float64(2.5) * np.ones(()),
        "label": "x",
    }
    out = decode_answer(binary.encode(values))
    np.testing.assert_array_equal(out["m"], values["m"])
    assert out["s"].shape == () and float(out["s"]) == 2.5 and out["label"] == "x"


def test_requests_written_by_the_safetensors_library_are_read(api, catalog_registry):
    """A body written by `safetensors.numpy.save` (fields as JSON texts in the metadata) gives
    the JSON answer; the answer, read back by the library, is bit for bit the JSON one."""
    model = catalog_registry.catalog["talos"].model
    s = states(model, 50, seed=3)
    body = safetensors.numpy.save(
        {"q": s["q"], "v": s["v"]},
        metadata={"frame": '"arm_left_7_joint"', "reference_frame": '"world"'},
    )
    r = api.post(
        "/v1/robots/talos/jacobian", content=body, headers={"content-type": BIN, "accept": BIN}
    )
    assert r.status_code == 200, r.text
    expected = api.post(
        "/v1/robots/talos/jacobian",
        json={
            "q": s["q"].tolist(),
            "v": s["v"].tolist(),
            "frame": "arm_left_7_joint",
            "reference_frame": "world",
        },
    ).json()
    got = safetensors.numpy.load(r.content)
    assert set(got) == set(expected)
    for key, value in expected.items():
        assert got[key].dtype == np.float64
        np.testing.assert_array_equal(got[key], np.asarray(value))


def test_answers_read_by_safetensors_torch_are_bit_for_bit_the_json_answers(api, catalog_registry):
    torch = pytest.importorskip("torch")
    import safetensors.torch

    model = catalog_registry.catalog["talos"].model
    s = states(model, 20, seed=4)
    body = {"q": s["q"], "v": s["v"], "a": s["a"]}
    r = api.post(
        "/v1/robots/talos/inverse-dynamics-derivatives",
        content=encode_request(body),
        headers={"content-type": BIN, "accept": BIN},
    )
    expected = api.post(
        "/v1/robots/talos/inverse-dynamics-derivatives",
        json={k: v.tolist() for k, v in body.items()},
    ).json()
    got = safetensors.torch.load(r.content)
    for key, value in expected.items():
        assert got[key].dtype == torch.float64
        np.testing.assert_array_equal(got[key].numpy(), np.asarray(value))
    written = safetensors.torch.save({k: torch.from_numpy(v) for k, v in body.items()})
    r = api.post(
        "/v1/robots/talos/inverse-dynamics-derivatives",
        content=written,
        headers={"content-type": BIN, "accept": BIN},
    )
    assert r.status_code == 200, r.text  # a request written by safetensors.torch
    for key, value in safetensors.torch.load(r.content).items():
        np.testing.assert_array_equal(value.numpy(), np.asarray(expected[key]))


def test_a_zero_size_dimension_with_a_huge_one_is_refused_before_any_allocation(api):
    """[0, 2**63] has no numbers, but numpy cannot represent the shape: a 422, never a 500."""
    for shape in ([0, 2**63], [0, 2**62, 2**62], [2**63]):
        content = raw({"q": {"dtype": "F64", "shape": shape, "data_offsets": [0, 0]}})
        r = api.post("/v1/robots/ur5/mass-matrix", content=content, headers={"content-type": BIN})
        assert "shape" in _problem(r, "validation_error")


@pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")
def test_the_javascript_reader_gives_the_json_answer_bit_for_bit(api, catalog_registry, tmp_path):
    """tests/js/read_safetensors.mjs (the reader of docs/binary-format.md) under Node."""
    model = catalog_registry.catalog["talos"].model
    s = states(model, 30, seed=6)
    body = {"q": s["q"], "v": s["v"]}
    r = api.post(
        "/v1/robots/talos/centroidal",
        content=encode_request(body),
        headers={"content-type": BIN, "accept": BIN},
    )
    (tmp_path / "answer.safetensors").write_bytes(r.content)
    script = Path(__file__).parents[3] / "js" / "read_safetensors.mjs"
    out = subprocess.run(
        ["node", str(script), str(tmp_path / "answer.safetensors")],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    ).stdout
    read = orjson.loads(out)
    expected = api.post(
        "/v1/robots/talos/centroidal", json={k: v.tolist() for k, v in body.items()}
    ).json()
    assert read["fields"] == {} and set(read["tensors"]) == set(expected)
    for key, value in expected.items():
        tensor = read["tensors"][key]
        got = np.array(tensor["values"], dtype=np.float64).reshape(tensor["shape"])
        assert got.shape == np.asarray(value).shape
        assert got.tobytes() == np.asarray(value, dtype=np.float64).tobytes()


def test_the_former_media_type_is_unsupported(api):
    r = api.post(
        "/v1/robots/ur5/gravity",
        content=b"RDY1" + bytes(60),
        headers={"content-type": "application/vnd.robodyn.binary"},
    )
    assert r.status_code == 415 and BIN in r.json()["detail"]


def test_openapi_documents_the_dynamics_routes_and_the_binary_form(api):
    doc = api.get("/openapi.json").json()
    for quantity in INPUTS:
        op = doc["paths"][f"/v1/robots/{{robot_id}}/{quantity}"]["post"]
        assert "requestBody" in op and "200" in op["responses"]
        assert op["x-binary-media-type"] == BIN
        assert "binary" in op["description"]
