"""Client methods of identification — inertial_parameters, regressor, identify — sync and
async against the app in process, checked against the in-process physics; errors and local
input checks."""

from __future__ import annotations

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
    return synthetic_log(registry.get("ur5").model, seed=3, duration=8.0, rate=100.0,
                         noise=0.05)


def test_inertial_parameters_and_regressor(client: Client, registry: Any) -> None:
    robot = registry.get("panda")
    got = client.inertial_parameters("panda")
    assert isinstance(got, robodyn.InertialParameters)
    np.testing.assert_array_equal(got.parameters, inertial_parameters(robot.model))
    assert got.bodies[0] == "panda_joint1" and got.of("panda_joint2")[0] == \
        robot.model.inertias[2].mass
    rng = np.random.default_rng(2)
    q, v, a = rng.uniform(-1, 1, (3, 4, robot.nv))
    np.testing.assert_array_equal(client.regressor("panda", q, v, a),
                                  regressor(robot, q, v, a))
    np.testing.assert_array_equal(client.regressor("panda", q[0], v[0], a[0]),
                                  regressor(robot, q[:1], v[:1], a[:1])[0])


def test_identify(client: Client, registry: Any, log: Any) -> None:
    # plain lists (any columns numpy reads) in, numpy out
    result = client.identify("ur5", log.t.tolist(), log.q.tolist(), log.tau.tolist(),
                             store=False, include_series=True)
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
    result = client.identify("ur5", log.t, log.q, log.tau, store=False,
                             payload_frame="tool0", friction="viscous")
    assert result.payload is not None
    assert all(f.coulomb == 0.0 for f in result.friction)


def test_identify_errors(client: Client, log: Any, registry: Any) -> None:
    talos = registry.get("talos")
    with pytest.raises(robodyn.UnsupportedModelError, match="fixed-base"):
        client.identify("talos", log.t, np.tile(talos.default_configuration, (log.t.size, 1)),
                        np.zeros((log.t.size, talos.nv)), store=False)
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
    async with httpx.AsyncClient(transport=transport, base_url="http://app") as http, \
            AsyncClient(http_client=http) as client:
        result = await client.identify("ur5", log.t, log.q, log.tau, v=log.v, a=log.a,
                                       method="least-squares", store=False)
        parameters = await client.inertial_parameters("ur5")
    here = identify(registry.get("ur5"), log.t, log.q, log.tau, v=log.v, a=log.a,
                    method="least-squares")
    np.testing.assert_allclose(result.base_parameters.values,
                               here.base_parameters["values"], rtol=1e-9, atol=1e-12)
    assert parameters.layout[0] == "m"


