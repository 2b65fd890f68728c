"""Identification over HTTP: GET inertial-parameters, POST regressor (JSON and binary) and
POST identify answer what the in-process physics computes; every bad input is a 422 with the
contract's code, never a 5xx."""

from __future__ import annotations

import re

import numpy as np
import orjson
import pytest
from fastapi.testclient import TestClient

from service.dynamics.identification import identify, inertial_parameters, regressor
from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.service.api.encoding.test_binary import BIN, decode_answer, encode_request
from tests.service.dynamics.identification_logs import synthetic_log


@pytest.fixture(scope="module")
def registry(tmp_path_factory):
    registry = Registry(tmp_path_factory.mktemp("store"), ["ur5", "bolt", "panda"])
    registry.load()
    return registry


@pytest.fixture(scope="module")
def client(registry):
    settings = Settings(
        data_dir=registry.store.dir.parent, catalog="ur5,bolt,panda", max_identify_samples=5000
    )
    with TestClient(
        create_app(settings, registry=registry), raise_server_exceptions=False
    ) as client:
        yield client


@pytest.fixture(scope="module")
def log(registry):
    return synthetic_log(registry.get("ur5").model, seed=1, duration=8.0, rate=100.0, noise=0.05)


def _body(log, **extra):
    return {"t": log.t.tolist(), "q": log.q.tolist(), "tau": log.tau.tolist(), **extra}


def _problem(response, status, code):
    assert response.status_code == status, response.text
    assert response.headers["content-type"].startswith("application/problem+json")
    body = response.json()
    assert body["code"] == code
    return body["detail"]


def test_inertial_parameters(client, registry):
    answer = client.get("/v1/robots/panda/inertial-parameters").json()
    model = registry.get("panda").model
    assert answer["bodies"] == list(model.names)[1:]
    assert answer["layout"] == [
        "m",
        "m_cx",
        "m_cy",
        "m_cz",
        "Ixx",
        "Ixy",
        "Iyy",
        "Ixz",
        "Iyz",
        "Izz",
    ]
    np.testing.assert_array_equal(answer["parameters"], inertial_parameters(model))
    _problem(client.get("/v1/robots/nope/inertial-parameters"), 404, "robot_not_found")


def test_regressor_json_and_binary(client, registry):
    robot = registry.get("ur5")
    rng = np.random.default_rng(1)
    q, v, a = rng.uniform(-2, 2, (3, 4, 6))
    expected = regressor(robot, q, v, a)
    one = client.post(
        "/v1/robots/ur5/regressor",
        json={"q": q[0].tolist(), "v": v[0].tolist(), "a": a[0].tolist()},
    ).json()
    np.testing.assert_array_equal(one["regressor"], expected[0])
    batch = client.post(
        "/v1/robots/ur5/regressor", json={"q": q.tolist(), "v": v.tolist(), "a": a.tolist()}
    ).json()
    np.testing.assert_array_equal(batch["regressor"], expected)
    raw = client.post(
        "/v1/robots/ur5/regressor",
        content=encode_request({"q": q, "v": v, "a": a}),
        headers={"Content-Type": BIN, "Accept": BIN},
    )
    assert raw.status_code == 200
    np.testing.assert_array_equal(decode_answer(raw.content)["regressor"], expected)
    _problem(
        client.post(
            "/v1/robots/ur5/regressor",
            json={"q": q[0].tolist()[:5], "v": v[0].tolist(), "a": a[0].tolist()},
        ),
        422,
        "dimension_mismatch",
    )


def test_identify_answers_the_in_process_fit(client, registry, log):
    response = client.post(
        "/v1/robots/ur5/identify", json=_body(log, store=False, include_series=True)
    )
    assert response.status_code == 200, response.text
    answer = response.json()
    here = identify(registry.get("ur5"), log.t, log.q, log.tau)
    np.testing.assert_allclose(answer["parameters"], here.parameters, rtol=1e-9, atol=1e-12)
    for key in ("train", "validation", "validation_before"):
        np.testing.assert_allclose(answer["rmse"][key], here.rmse[key], rtol=1e-9)
    assert answer["base_parameters"]["expressions"] == here.base_parameters["expressions"]
    assert answer["physically_consistent"] is True
    assert answer["robot"] is None and answer["payload"] is None
    assert answer["condition_number"] == pytest.approx(here.condition_number)
    assert [f["joint"] for f in answer["friction"]] == [b["name"] for b in answer["bodies"]]
    series = answer["validation_series"]
    assert len(series["t"]) == answer["samples"]["validation"] == len(series["measured"])
    np.testing.assert_allclose(
        series["predicted"], here.validation["predicted"], rtol=1e-9, atol=1e-12
    )


def test_identify_a_payload(client, log):
    answer = client.post(
        "/v1/robots/ur5/identify",
        json=_body(log, store=False, method="least-squares", payload={"frame": "tool0"}),
    ).json()
    assert set(answer["payload"]) == {"frame", "mass", "center_of_mass", "inertia"}
    assert answer["payload"]["frame"] == "tool0"


@pytest.mark.parametrize(
    ("change", "code", "words"),
    [
        ({"q": "rows of 5"}, "dimension_mismatch", "each row of q must have 6 entries"),
        ({"tau": "one row fewer"}, "dimension_mismatch", "tau has 799 rows; t has 800"),
        ({"t": "repeated sample"}, "validation_error", "strictly increasing"),
        ({"t": "first 40"}, "validation_error", "needs at least"),
        ({"friction": "stribeck"}, "validation_error", "friction"),
        ({"method": "magic"}, "validation_error", "method"),
        ({"validation_fraction": 0.9}, "validation_error", "validation_fraction"),
        ({"filter_hz": 80.0}, "validation_error", "filter_hz"),
        ({"payload": {"frame": "tool00"}}, "unknown_frame", "did you mean 'tool0'"),
        ({"t": "over the sample limit"}, "dimension_mismatch", "ROBODYN_MAX_IDENTIFY_SAMPLES"),
    ],
)
def test_identify_bad_input(client, log, change, code, words):
    body = _body(log, store=False)
    ((key, value),) = change.items()
    if value == "rows of 5":
        body["q"] = [row[:5] for row in body["q"]]
    elif value == "one row fewer":
        body["tau"] = body["tau"][:-1]
    elif value == "repeated sample":
        body["t"][5] = body["t"][4]
    elif value == "first 40":
        body = {k: body[k][:40] for k in ("t", "q", "tau")}
    elif value == "over the sample limit":
        body = {k: body[k] * 7 for k in ("t", "q", "tau")}
    else:
        body[key] = value
    detail = _problem(client.post("/v1/robots/ur5/identify", json=body), 422, code)
    assert words in detail


def test_identify_non_finite_and_malformed(client, log):
    text = orjson.dumps(_body(log, store=False)).decode()
    broken = text.replace(str(log.tau[3][2]), "NaN", 1)
    assert broken != text
    _problem(
        client.post(
            "/v1/robots/ur5/identify", content=broken, headers={"Content-Type": "application/json"}
        ),
        422,
        "validation_error",
    )
    _problem(
        client.post(
            "/v1/robots/ur5/identify",
            content=b"{not json",
            headers={"Content-Type": "application/json"},
        ),
        422,
        "validation_error",
    )
    _problem(client.post("/v1/robots/ur5/identify", json={"t": [0, 1]}), 422, "validation_error")
    _problem(client.post("/v1/robots/nope/identify", json=_body(log)), 404, "robot_not_found")


@pytest.mark.parametrize(
    ("scaled", "factor", "words"),
    [
        (("q",), 1e300, r"\|q\| up to [0-9.]+e\+(299|300)"),  # v² overflows: the regressor
        (("v", "a"), 1e150, r"\|v\| up to [0-9.]+e\+150"),  # squares overflow in the fit
    ],
)
def test_identify_numbers_too_large_to_fit_are_a_422(client, log, scaled, factor, words):
    """Through the worker process: the log's numbers whose squares overflow float64 in the fit
    are a 422 validation_error naming them, never a 500."""
    body = _body(log, store=False, v=log.v.tolist(), a=log.a.tolist())
    for name in scaled:
        body[name] = (np.asarray(body[name]) * factor).tolist()
    if "v" not in scaled:
        del body["v"], body["a"]  # differentiated from q
    detail = _problem(client.post("/v1/robots/ur5/identify", json=body), 422, "validation_error")
    assert "too large to fit in float64" in detail and re.search(words, detail), detail


def test_identify_a_free_flyer_is_unsupported(client, registry):
    robot = registry.get("bolt")
    n = 300
    q = np.tile(np.asarray(robot.default_configuration), (n, 1))
    detail = _problem(
        client.post(
            "/v1/robots/bolt/identify",
            json={
                "t": np.arange(n).tolist(),
                "q": q.tolist(),
                "tau": np.zeros((n, robot.nv)).tolist(),
                "store": False,
            },
        ),
        422,
        "unsupported_model",
    )
    assert "fixed-base" in detail


def test_identify_stores_a_variant_with_its_friction(client, registry, log):
    from service.dynamics.identification import with_inertial_parameters

    answer = client.post("/v1/robots/ur5/identify", json=_body(log)).json()
    info = answer["robot"]
    assert info["id"].startswith("v-") and info["parent"] == "ur5"
    assert answer["not_stored"] is None
    assert [f["joint"] for f in info["friction"]] == [f["joint"] for f in answer["friction"]]
    np.testing.assert_allclose(info["modifications"]["inertial_parameters"], answer["parameters"])
    again = client.post("/v1/robots/ur5/identify", json=_body(log)).json()
    assert again["robot"]["id"] == info["id"]  # the same log, the same robot
    # the stored robot computes with the identified parameters and friction
    model = with_inertial_parameters(registry.get("ur5").model, np.array(answer["parameters"]))
    rng = np.random.default_rng(6)
    q, v, a = rng.uniform(-1, 1, (3, 6))
    tau = client.post(
        f"/v1/robots/{info['id']}/inverse-dynamics",
        json={"q": q.tolist(), "v": v.tolist(), "a": a.tolist(), "friction": True},
    ).json()["tau"]
    coulomb, viscous, offset = (
        np.array([f[k] for f in answer["friction"]]) for k in ("coulomb", "viscous", "offset")
    )
    import pinocchio as pin

    expected = (
        pin.rnea(model, model.createData(), q, v, a) + offset + coulomb * np.sign(v) + viscous * v
    )
    np.testing.assert_allclose(tau, expected, rtol=1e-9, atol=1e-9)
    plain = client.post(
        "/v1/robots/ur5/inverse-dynamics",
        json={"q": q.tolist(), "v": v.tolist(), "a": a.tolist(), "friction": True},
    )
    _problem(plain, 422, "validation_error")
    # a registry restarted on the same store rebuilds it, friction included
    again_registry = Registry(registry.store.dir.parent, ["ur5"])
    again_registry.load()
    rebuilt = again_registry.get(info["id"])
    assert rebuilt.info()["friction"] == info["friction"]
    np.testing.assert_allclose(
        pin.crba(rebuilt.model, rebuilt.model.createData(), q),
        pin.crba(model, model.createData(), q),
        rtol=1e-12,
        atol=1e-12,
    )


def test_identify_stores_a_payload_variant(client, registry):
    import pinocchio as pin

    from tests.service.dynamics.identification_logs import loaded_parameters

    model = registry.get("ur5").model
    box = pin.Inertia(1.2, np.array([0.0, 0.01, 0.06]), np.diag([0.003, 0.004, 0.002]))
    held_log = synthetic_log(
        model,
        seed=7,
        duration=10.0,
        rate=100.0,
        noise=0.05,
        pi=loaded_parameters(model, "tool0", box),
    )
    answer = client.post(
        "/v1/robots/ur5/identify", json=_body(held_log, payload={"frame": "tool0"})
    ).json()
    assert answer["payload"]["mass"] == pytest.approx(1.2, rel=0.02)
    info = answer["robot"]
    assert answer["not_stored"] is None and info["parent"] == "ur5"
    assert info["modifications"]["payloads"][0]["frame"] == "tool0"
    q = [0.1, -1.2, 1.0, 0.3, 0.2, 0.1]
    held = client.post(f"/v1/robots/{info['id']}/gravity", json={"q": q}).json()["gravity"]
    direct = client.post(
        "/v1/robots/ur5/gravity", json={"q": q, "payloads": [answer["payload"]]}
    ).json()["gravity"]
    np.testing.assert_allclose(held, direct, rtol=1e-9, atol=1e-9)


def test_an_inconsistent_least_squares_fit_is_not_stored(client, log):
    answer = client.post("/v1/robots/ur5/identify", json=_body(log, method="least-squares")).json()
    assert answer["physically_consistent"] is False  # (this log: two bodies' inertias)
    assert answer["robot"] is None and "not physically consistent" in answer["not_stored"]


def test_identify_needs_the_api_key(registry, log, tmp_path):
    """It stores a model (by default): a write, like an upload, whatever the body."""
    settings = Settings(
        data_dir=registry.store.dir.parent, catalog="ur5,bolt,panda", api_keys="secret"
    )
    with TestClient(
        create_app(settings, registry=registry), raise_server_exceptions=False
    ) as keyed:
        _problem(keyed.post("/v1/robots/ur5/identify", json=_body(log)), 401, "unauthorized")
        _problem(keyed.post("/v1/robots/ur5/identify", json={}), 401, "unauthorized")
        assert (
            keyed.post(
                "/v1/robots/ur5/identify",
                json=_body(log, store=False),
                headers={"Authorization": "Bearer secret"},
            ).status_code
            == 200
        )
