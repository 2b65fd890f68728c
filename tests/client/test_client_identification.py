"""Client methods of identification — inertial_parameters, regressor, identify — sync and
async against the app in process, checked against the in-process physics; errors and local
input checks."""

from __future__ import annotations

import json
from typing import Any

import httpx
import numpy as np
import pytest
import robodyn
from fastapi.testclient import TestClient
from robodyn import AsyncClient, Client

from service.dynamics.identification import identify, inertial_parameters, regressor
from tests.service.dynamics.identification_logs import synthetic_log


@pytest.fixture(scope="module")
def client(app: Any) -> Any:
    with TestClient(app) as http, Client(http_client=http) as client:
        yield client


@pytest.fixture(scope="module")
def log(registry: Any) -> Any:
    return synthetic_log(registry.get("ur5").model, seed=3, duration=8.0, rate=100.0, noise=0.05)


def test_inertial_parameters_and_regressor(client: Client, registry: Any) -> None:
    robot = registry.get("panda")
    got = client.inertial_parameters("panda")
    assert isinstance(got, robodyn.InertialParameters)
    np.testing.assert_array_equal(got.parameters, inertial_parameters(robot.model))
    assert (
        got.bodies[0] == "panda_joint1"
        and got.of("panda_joint2")[0] == robot.model.inertias[2].mass
    )
    rng = np.random.default_rng(2)
    q, v, a = rng.uniform(-1, 1, (3, 4, robot.nv))
    np.testing.assert_array_equal(client.regressor("panda", q, v, a), regressor(robot, q, v, a))
    np.testing.assert_array_equal(
        client.regressor("panda", q[0], v[0], a[0]), regressor(robot, q[:1], v[:1], a[:1])[0]
    )


def test_identify(client: Client, registry: Any, log: Any) -> None:
    # plain lists (any columns numpy reads) in, numpy out
    result = client.identify(
        "ur5", log.t.tolist(), log.q.tolist(), log.tau.tolist(), store=False, include_series=True
    )
    here = identify(registry.get("ur5"), log.t, log.q, log.tau)
    assert isinstance(result, robodyn.Identification)
    np.testing.assert_allclose(result.parameters, here.parameters, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(result.rmse.validation, here.rmse["validation"], rtol=1e-9)
    assert result.robot is None and result.robot_id is None
    assert result.physically_consistent and result.condition_number is not None
    assert [f.joint for f in result.friction] == [b.name for b in result.bodies]
    assert result.validation_series is not None
    assert result.validation_series["predicted"].shape == (result.samples["validation"], 6)
    assert len(result.base_parameters.expressions) == result.base_parameters.values.size


def test_identify_a_payload_answers_a_payload(client: Client, log: Any) -> None:
    result = client.identify(
        "ur5", log.t, log.q, log.tau, store=False, payload_frame="tool0", friction="viscous"
    )
    assert result.payload is not None
    assert all(f.coulomb == 0.0 for f in result.friction)


def test_identify_errors(client: Client, log: Any, registry: Any) -> None:
    talos = registry.get("talos")
    with pytest.raises(robodyn.UnsupportedModelError, match="fixed-base"):
        client.identify(
            "talos",
            log.t,
            np.tile(talos.default_configuration, (log.t.size, 1)),
            np.zeros((log.t.size, talos.nv)),
            store=False,
        )
    with pytest.raises(robodyn.ValidationError, match="needs at least"):
        client.identify("ur5", log.t[:30], log.q[:30], log.tau[:30], store=False)
    with pytest.raises(robodyn.DimensionMismatchError):
        client.identify("ur5", log.t, log.q[:, :5], log.tau, store=False)
    with pytest.raises(robodyn.InputError, match="t must be"):
        client.identify("ur5", log.q, log.q, log.tau)
    with pytest.raises(robodyn.InputError, match="friction must be one of"):
        client.identify("ur5", log.t, log.q, log.tau, friction="stribeck")  # type: ignore[arg-type]


@pytest.mark.anyio
async def test_async_identify(app: Any, registry: Any, log: Any) -> None:
    transport = httpx.ASGITransport(app=app)
    async with (
        httpx.AsyncClient(transport=transport, base_url="http://app") as http,
        AsyncClient(http_client=http) as client,
    ):
        result = await client.identify(
            "ur5", log.t, log.q, log.tau, v=log.v, a=log.a, method="least-squares", store=False
        )
        parameters = await client.inertial_parameters("ur5")
    here = identify(
        registry.get("ur5"), log.t, log.q, log.tau, v=log.v, a=log.a, method="least-squares"
    )
    np.testing.assert_allclose(
        result.base_parameters.values, here.base_parameters["values"], rtol=1e-9, atol=1e-12
    )
    assert parameters.layout[0] == "m"


@pytest.mark.anyio
async def test_async_identify_names_a_joint_that_barely_moves(
    client: Client, app: Any, log: Any
) -> None:
    """wrist_3 trembles over 0.006 rad: a warning names it, its friction is None. (`client`:
    the app's lifespan, which ends its identification worker.)"""
    q, v = log.q.copy(), log.v.copy()
    q[:, 5] = 0.2 + 0.003 * np.sin(3.0 * log.t)
    v[:, 5] = 0.009 * np.cos(3.0 * log.t)
    a = log.a.copy()
    a[:, 5] = -0.027 * np.sin(3.0 * log.t)
    transport = httpx.ASGITransport(app=app)
    async with (
        httpx.AsyncClient(transport=transport, base_url="http://app") as http,
        AsyncClient(http_client=http) as client,
    ):
        result = await client.identify("ur5", log.t, q, log.tau, v=v, a=a, store=False)
    assert result.warnings == (
        robodyn.IdentificationWarning(
            "unexcited_joint", "wrist_3_joint", result.warnings[0].detail
        ),
    )
    assert "wrist_3_joint moves over 0.006 rad" in result.warnings[0].detail
    assert result.friction[5] is None and isinstance(result.friction[0], robodyn.JointFriction)


def _recording_client(app: Any, seen: list[httpx.Request], **options: Any) -> Any:
    """A TestClient on the app whose requests are recorded, bodies read (`request.read()`
    keeps them sendable), and a robodyn Client over it."""

    def record(request: httpx.Request) -> None:
        request.read()
        seen.append(request)

    http = TestClient(app)
    http.event_hooks = {"request": [record], "response": []}
    return http, Client(http_client=http, **options)


def test_identify_sends_a_large_log_in_the_binary_form(app: Any, registry: Any, log: Any) -> None:
    """800 samples × (t, 6 q, 6 τ) are over `BINARY_FROM` numbers: a safetensors body with t,
    q, tau as F64 tensors, bit for bit, the options in its metadata; the answer is the
    in-process fit, and the same as the JSON form's (`binary=False`)."""
    seen: list[httpx.Request] = []
    http, client = _recording_client(app, seen)
    with http, client:
        result = client.identify("ur5", log.t, log.q, log.tau, store=False, friction="viscous")
    (sent,) = seen
    assert sent.headers["content-type"] == robodyn.binary.MEDIA_TYPE
    assert log.t.size * 13 >= robodyn.core.BINARY_FROM
    body = robodyn.binary.decode(sent.content)
    for name in ("t", "q", "tau"):
        np.testing.assert_array_equal(body[name], getattr(log, name))
    assert body["t"].shape == (log.t.size,)
    assert body["friction"] == "viscous" and body["store"] is False
    here = identify(registry.get("ur5"), log.t, log.q, log.tau, friction="viscous")
    np.testing.assert_allclose(result.parameters, here.parameters, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(result.rmse.validation, here.rmse["validation"], rtol=1e-9)
    # forced JSON: the same log as lists (t a list too), the same answer
    seen.clear()
    http, client = _recording_client(app, seen, binary=False)
    with http, client:
        again = client.identify("ur5", log.t, log.q, log.tau, store=False, friction="viscous")
    assert seen[0].headers["content-type"] == "application/json"
    sent_json = json.loads(seen[0].content)
    assert sent_json["t"] == log.t.tolist() and sent_json["q"] == log.q.tolist()
    np.testing.assert_allclose(again.parameters, result.parameters, rtol=1e-9, atol=1e-12)


def test_identify_sends_a_small_log_as_json(app: Any, log: Any) -> None:
    """A log under `BINARY_FROM` numbers stays JSON (here too short to identify: the server's
    422 comes back as a ValidationError)."""
    seen: list[httpx.Request] = []
    http, client = _recording_client(app, seen)
    with http, client, pytest.raises(robodyn.ValidationError, match="needs at least"):
        client.identify("ur5", log.t[:40], log.q[:40], log.tau[:40], store=False)
    assert seen[0].headers["content-type"] == "application/json"
    assert json.loads(seen[0].content)["t"] == log.t[:40].tolist()


def test_identify_a_still_robot_is_a_validation_error(
    client: Client, registry: Any, log: Any
) -> None:
    import pinocchio as pin

    model = registry.get("ur5").model
    q = np.repeat(log.q[:1], log.t.size, axis=0)
    tau = np.tile(pin.computeGeneralizedGravity(model, model.createData(), q[0]), (log.t.size, 1))
    with pytest.raises(robodyn.ValidationError, match="too little motion") as raised:
        client.identify("ur5", log.t, q, tau, store=False)
    assert "shoulder_pan_joint 0 rad" in str(raised.value)
