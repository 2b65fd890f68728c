"""POST identify in the binary form (a safetensors file: t, q, tau, v, a as F64 tensors, the
options in `__metadata__`): the same answer as the JSON form on the same log, every bad tensor
or option a 422 naming it, another media type a 415; and a log in which the robot does not
move is a clear 422 in either form."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest
import safetensors.numpy
from fastapi.testclient import TestClient

from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.service.api.encoding.test_binary import BIN, encode_request
from tests.service.dynamics.identification_logs import synthetic_log

ROUTE = "/v1/robots/ur5/identify"


@pytest.fixture(scope="module")
def registry(tmp_path_factory):
    registry = Registry(tmp_path_factory.mktemp("store"), ["ur5"])
    registry.load()
    return registry


@pytest.fixture(scope="module")
def client(registry):
    settings = Settings(
        data_dir=registry.store.dir.parent, catalog="ur5", max_identify_samples=5000
    )
    with TestClient(
        create_app(settings, registry=registry), raise_server_exceptions=False
    ) as client:
        yield client


@pytest.fixture(scope="module")
def log(registry):
    return synthetic_log(registry.get("ur5").model, seed=2, duration=8.0, rate=100.0, noise=0.05)


def _tensors(log, **extra):
    return {"t": log.t, "q": log.q, "tau": log.tau, **extra}


def _post_binary(client, arrays, fields=None, **headers):
    return client.post(
        ROUTE, content=encode_request(arrays, fields), headers={"Content-Type": BIN, **headers}
    )


def _problem(response, status, code):
    assert response.status_code == status, response.text
    assert response.headers["content-type"].startswith("application/problem+json")
    body = response.json()
    assert body["code"] == code
    return body["detail"]


def _same_answer(binary_answer, json_answer):
    for key in ("parameters", "condition_number"):
        np.testing.assert_allclose(binary_answer[key], json_answer[key], rtol=1e-9, atol=1e-12)
    for key in ("values", "standard_deviation"):
        np.testing.assert_allclose(
            binary_answer["base_parameters"][key],
            json_answer["base_parameters"][key],
            rtol=1e-9,
            atol=1e-12,
        )
    for key in ("train", "validation", "validation_before"):
        np.testing.assert_allclose(binary_answer["rmse"][key], json_answer["rmse"][key], rtol=1e-9)
    for a, b in zip(binary_answer["friction"], json_answer["friction"], strict=True):
        assert a["joint"] == b["joint"]
        np.testing.assert_allclose(
            [a[k] for k in ("coulomb", "viscous", "offset")],
            [b[k] for k in ("coulomb", "viscous", "offset")],
            rtol=1e-9,
            atol=1e-12,
        )
    assert binary_answer["samples"] == json_answer["samples"]
    assert (
        binary_answer["base_parameters"]["expressions"]
        == json_answer["base_parameters"]["expressions"]
    )


def test_the_binary_form_gives_the_json_answer(client, log):
    options = {"store": False, "include_series": True}
    by_json = client.post(ROUTE, json={k: v.tolist() for k, v in _tensors(log).items()} | options)
    assert by_json.status_code == 200, by_json.text
    # written by the safetensors library itself: any safetensors writer makes a valid body
    body = safetensors.numpy.save(
        _tensors(log), metadata={"store": "false", "include_series": "true"}
    )
    by_binary = client.post(ROUTE, content=body, headers={"Content-Type": BIN, "Accept": BIN})
    assert by_binary.status_code == 200, by_binary.text
    assert by_binary.headers["content-type"] == "application/json"  # the answer stays JSON
    answer = by_binary.json()
    _same_answer(answer, by_json.json())
    np.testing.assert_allclose(
        answer["validation_series"]["predicted"],
        by_json.json()["validation_series"]["predicted"],
        rtol=1e-9,
        atol=1e-12,
    )
    assert answer["robot"] is None and answer["physically_consistent"] is True


def test_the_binary_form_with_v_a_and_options(client, log):
    """The optional tensors and the options (a payload's frame: an object in __metadata__)
    travel as in JSON and give the same fit."""
    options = {
        "store": False,
        "method": "least-squares",
        "friction": "viscous",
        "payload": {"frame": "tool0"},
        "validation_fraction": 0.25,
    }
    arrays = _tensors(log, v=log.v, a=log.a)
    by_json = client.post(ROUTE, json={k: v.tolist() for k, v in arrays.items()} | options)
    by_binary = _post_binary(client, arrays, options)
    assert by_binary.status_code == 200, by_binary.text
    _same_answer(by_binary.json(), by_json.json())
    assert by_binary.json()["payload"] == by_json.json()["payload"]
    assert by_binary.json()["filter_hz"] is None  # v and a given: the log used as it is


def test_a_binary_identify_stores_the_same_variant(client, log):
    """store (the default) makes the same variant as the JSON form of the same log."""
    by_binary = _post_binary(client, _tensors(log), {"friction": "none"})
    assert by_binary.status_code == 200, by_binary.text
    by_json = client.post(
        ROUTE, json={k: v.tolist() for k, v in _tensors(log).items()} | {"friction": "none"}
    ).json()
    stored = by_binary.json()["robot"]
    assert stored is not None and stored["parent"] == "ur5"
    assert stored["id"] == by_json["robot"]["id"]  # the same log, the same robot


def _bad(log, change):
    """(arrays, fields) of the log with one fault."""
    arrays, fields = _tensors(log), {"store": False}
    if change == "t 2-D":
        arrays["t"] = log.t[:, None]
    elif change == "q 1-D":
        arrays["q"] = log.q[:, 0]
    elif change == "no tau":
        del arrays["tau"]
    elif change == "NaN in tau":
        arrays["tau"] = log.tau.copy()
        arrays["tau"][3, 2] = np.nan
    elif change == "inf in t":
        arrays["t"] = log.t.copy()
        arrays["t"][7] = np.inf
    elif change == "unknown tensor":
        arrays["w"] = log.v
    elif change == "t in metadata":
        fields["t"] = arrays.pop("t").tolist()
    elif change == "q of 5":
        arrays["q"] = log.q[:, :5]
    elif change == "a row short":
        arrays["v"], arrays["a"] = log.v[:-1], log.a
    elif change == "bad friction":
        fields["friction"] = "stribeck"
    elif change == "unknown option":
        fields["frobnicate"] = 1
    elif change == "store as text":
        fields["store"] = "no"
    elif change == "over the sample limit":
        arrays = {k: np.concatenate([a] * 7) for k, a in arrays.items()}
    return arrays, fields


@pytest.mark.parametrize(
    ("change", "code", "words"),
    [
        ("t 2-D", "validation_error", "tensor t has shape [800, 1]; it must be [N]"),
        ("q 1-D", "validation_error", "tensor q has shape [800]; it must be [N, nq]"),
        ("no tau", "validation_error", "missing tensor 'tau'"),
        ("NaN in tau", "validation_error", "tau[3, 2] is nan; every number must be finite"),
        ("inf in t", "validation_error", "t[7] is inf"),
        ("unknown tensor", "validation_error", "unknown tensor 'w'"),
        ("t in metadata", "validation_error", "t is in __metadata__; it goes as a tensor"),
        ("q of 5", "dimension_mismatch", "each row of q must have 6 entries"),
        ("a row short", "dimension_mismatch", "v has 799 rows; t has 800"),
        ("bad friction", "validation_error", "friction"),
        ("unknown option", "validation_error", "frobnicate"),
        ("store as text", "validation_error", "store"),
        ("over the sample limit", "dimension_mismatch", "ROBODYN_MAX_IDENTIFY_SAMPLES"),
    ],
)
def test_bad_binary_bodies_are_422_naming_the_fault(client, log, change, code, words):
    arrays, fields = _bad(log, change)
    detail = _problem(_post_binary(client, arrays, fields), 422, code)
    assert words in detail, detail


def test_a_wrong_dtype_or_a_broken_file_is_422(client, log):
    body = safetensors.numpy.save({"t": log.t, "q": log.q.astype(np.float32), "tau": log.tau})
    detail = _problem(
        client.post(ROUTE, content=body, headers={"Content-Type": BIN}), 422, "validation_error"
    )
    assert "tensor q has dtype 'F32'" in detail
    detail = _problem(
        client.post(ROUTE, content=b"\x10\x00\x00", headers={"Content-Type": BIN}),
        422,
        "validation_error",
    )
    assert detail.startswith("binary body:")


def test_other_media_types_are_415(client, log):
    for media_type in ("text/csv", "application/vnd.robodyn.binary", "multipart/form-data"):
        detail = _problem(
            client.post(ROUTE, content=b"t,q\n", headers={"Content-Type": media_type}),
            415,
            "unsupported_media_type",
        )
        assert BIN in detail


def test_the_openapi_document_declares_the_binary_request(client):
    operation = client.get("/openapi.json").json()["paths"]["/v1/robots/{robot_id}/identify"][
        "post"
    ]
    assert set(operation["requestBody"]["content"]) == {"application/json", BIN}
    assert operation["requestBody"]["content"]["application/json"]["schema"]["$ref"].endswith(
        "/IdentifyRequest"
    )
    # the answer: JSON, or the progress stream of the same JSON; never the binary form
    assert list(operation["responses"]["200"]["content"]) == [
        "application/json",
        "application/x-ndjson",
    ]
    assert operation["x-binary-media-type"] == BIN
    assert "415" in operation["responses"]


@pytest.mark.parametrize("form", ["json", "binary"])
def test_a_robot_that_does_not_move_is_a_clear_422(client, registry, log, form):
    """Constant q, τ = g(q) + noise: a validation_error that names every joint and says
    what is needed, before any fit (which would be not finite, or a fit of nothing)."""
    model = registry.get("ur5").model
    q = np.repeat(log.q[:1], log.t.size, axis=0)
    data = model.createData()
    tau = np.array([pin.computeGeneralizedGravity(model, data, x) for x in q])
    tau += np.random.default_rng(4).normal(0.0, 0.02, tau.shape)
    arrays = {"t": log.t, "q": q, "tau": tau}
    response = (
        client.post(ROUTE, json={k: v.tolist() for k, v in arrays.items()})
        if form == "json"
        else _post_binary(client, arrays)
    )
    detail = _problem(response, 422, "validation_error")
    assert detail.startswith("the log shows too little motion to identify robot 'ur5'")
    assert "every joint barely moves" in detail and "excite every joint" in detail
    assert all(f"{name} 0 rad" in detail for name in list(model.names)[1:])


def test_the_identify_example_of_the_binary_format_doc_runs(client, log):
    doc = (Path(__file__).parents[4] / "docs" / "binary-format.md").read_text()
    section = doc.split("## identify: a log in the binary form", 1)[1]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]

    def post(url, **options):
        options.pop("timeout", None)
        return client.post(url.removeprefix("http://127.0.0.1:8000"), **options)

    scope = {"t": log.t, "q": log.q, "tau": log.tau, "httpx": SimpleNamespace(post=post)}
    exec(code.replace("import httpx\n", ""), scope)
    answer = scope["r"].json()
    assert scope["r"].status_code == 200, answer
    assert answer["robot"] is None and all(f["coulomb"] == 0.0 for f in answer["friction"])
    assert len(answer["rmse"]["validation"]) == 6
