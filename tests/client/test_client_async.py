"""AsyncClient against the real app in process (httpx.ASGITransport), checked against Pinocchio."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import httpx
import numpy as np
import pytest
import robodyn
from robodyn import AsyncClient

from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.client.helpers import ATOL, CATALOG, RTOL, Reference, two_link_urdf

pytestmark = pytest.mark.anyio

QUANTITIES = {
    "mass_matrix": ("q",),
    "gravity": ("q",),
    "coriolis": ("q", "v"),
    "nonlinear_effects": ("q", "v"),
    "inverse_dynamics": ("q", "v", "a"),
    "forward_dynamics": ("q", "v", "tau"),
}


@asynccontextmanager
async def _client(app: Any, **options: Any) -> AsyncIterator[AsyncClient]:
    transport = httpx.ASGITransport(app=app)
    async with (
        httpx.AsyncClient(transport=transport, base_url="http://robodyn.test") as http,
        AsyncClient(http_client=http, **options) as client,
    ):
        yield client


@pytest.fixture
async def client(app: Any) -> AsyncIterator[AsyncClient]:
    async with _client(app) as c:
        yield c


def assert_same(got: Any, want: Any) -> None:
    if isinstance(want, tuple):
        assert isinstance(got, tuple) and len(got) == len(want)
        for g, w in zip(got, want, strict=True):
            assert_same(g, w)
        return
    assert isinstance(got, np.ndarray) and got.dtype == np.float64
    assert got.shape == want.shape
    np.testing.assert_allclose(got, want, rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("quantity", list(QUANTITIES))
@pytest.mark.parametrize("robot_id", CATALOG)
async def test_dynamics_equal_pinocchio_single_and_batch(
    client: AsyncClient, reference: Reference, robot_id: str, quantity: str
) -> None:
    states = reference.states(robot_id, 3, seed=len(quantity))
    inputs = [states[name] for name in QUANTITIES[quantity]]
    want = getattr(reference, quantity)(robot_id, *inputs)  # batch axis first
    method = getattr(client, quantity)

    batch = await method(robot_id, *inputs)
    assert_same(batch, want)
    for i in range(3):
        single = await method(robot_id, *(x[i] for x in inputs))
        assert_same(single, tuple(w[i] for w in want) if isinstance(want, tuple) else want[i])


async def test_robot_list_and_info(client: AsyncClient, registry: Registry) -> None:
    robots = await client.robots()
    assert sorted(r.id for r in robots if r.source == "catalog") == sorted(CATALOG)
    assert "talos" in robots and "nope" not in robots and robots.unavailable == {}
    talos = await client.robot("talos")
    model = registry.get("talos").model
    assert (talos.nq, talos.nv, talos.root_joint) == (model.nq, model.nv, "free-flyer")
    assert talos.joints[0].type == "free_flyer" and talos.joints[0].q_slice == slice(0, 7)
    knee = talos.joint("leg_left_4_joint")
    assert (knee.idx_q, knee.idx_v) == (
        model.idx_qs[model.getJointId(knee.name)],
        model.idx_vs[model.getJointId(knee.name)],
    )
    assert talos.total_mass == pytest.approx(float(sum(i.mass for i in model.inertias)))
    np.testing.assert_array_equal(talos.gravity, [0.0, 0.0, -9.81])
    assert "half_sitting" in talos.reference_configurations
    assert talos.raw["id"] == "talos" and talos.created is None
    with pytest.raises(KeyError, match="has no joint 'elbow'"):
        talos.joint("elbow")


async def test_upload_compute_delete(client: AsyncClient, reference: Reference) -> None:
    urdf = two_link_urdf(name="async_arm")
    arm = await client.upload(urdf.encode(), name="my arm")
    assert arm.created is True and arm.source == "upload" and arm.name == "my arm"
    assert (arm.nq, arm.nv, arm.joint_names) == (2, 2, ["shoulder", "elbow"])
    assert arm.joint("elbow").effort_limit == 20.0  # a float for a 1-DoF joint
    again = await client.upload(urdf)
    assert again.created is False and again.id == arm.id
    assert arm.id in await client.robots()

    reference.add_urdf(arm.id, urdf)
    s = reference.states(arm.id, 2)
    assert_same(
        await client.inverse_dynamics(arm.id, s["q"], s["v"], s["a"]),
        reference.inverse_dynamics(arm.id, s["q"], s["v"], s["a"]),
    )
    assert_same(
        await client.coriolis(arm.id, s["q"], s["v"]), reference.coriolis(arm.id, s["q"], s["v"])
    )

    await client.delete(arm.id)
    assert arm.id not in await client.robots()
    with pytest.raises(robodyn.RobotNotFoundError):
        await client.mass_matrix(arm.id, [0.0, 0.0])
    with pytest.raises(robodyn.RobotNotFoundError):
        await client.delete(arm.id)


async def test_server_errors_raise_their_classes(client: AsyncClient) -> None:
    with pytest.raises(robodyn.RobotNotFoundError) as not_found:
        await client.robot("no_such_robot")
    assert isinstance(not_found.value, LookupError) and not_found.value.status == 404
    with pytest.raises(robodyn.DimensionMismatchError, match="nq = 6") as dim:
        await client.gravity("ur5", np.zeros(5))
    assert isinstance(dim.value, ValueError) and dim.value.code == "dimension_mismatch"
    with pytest.raises(robodyn.InvalidConfigurationError, match="unit norm"):
        await client.gravity("talos", np.ones(39))
    with pytest.raises(robodyn.CatalogRobotError) as catalog:
        await client.delete("ur5")
    assert catalog.value.status == 409 and catalog.value.body["code"] == "catalog_robot"
    with pytest.raises(robodyn.NonFiniteResultError, match="not finite") as overflow:
        await client.coriolis("ur5", np.zeros(6), np.full(6, 1e200))  # C v overflows
    assert isinstance(overflow.value, ArithmeticError) and overflow.value.status == 422
    with pytest.raises(robodyn.ValidationError, match="root_joint"):
        await client.upload(two_link_urdf(), root_joint="sideways")
    with pytest.raises(robodyn.InvalidModelError, match="elbow"):
        await client.upload(
            two_link_urdf().replace('<child link="fore"/>', '<child link="missing"/>')
        )


async def test_inertia_check_reject_and_warn(client: AsyncClient) -> None:
    bad = two_link_urdf(name="bad_inertia").replace('ixx="1e-4"', 'ixx="-1"', 1)
    with pytest.raises(robodyn.InvalidModelError, match="upper"):
        await client.upload(bad)
    arm = await client.upload(bad, inertia_check="warn")
    try:
        assert arm.warnings, "a negative principal moment must be reported"
        finding = arm.warnings[0]
        assert (finding.element, finding.name) == ("link", "upper") and finding.message
    finally:
        await client.delete(arm.id)


async def test_api_key_is_sent_as_bearer(registry: Registry, tmp_path: Any) -> None:
    app = create_app(Settings(data_dir=tmp_path, api_keys="s3cret"), registry=registry)
    async with _client(app) as anonymous:
        with pytest.raises(robodyn.UnauthorizedError) as denied:
            await anonymous.upload(two_link_urdf(name="keyed"))
        assert isinstance(denied.value, PermissionError) and denied.value.status == 401
        assert (await anonymous.gravity("ur5", np.zeros(6))).shape == (6,)  # reads need no key
    async with _client(app, api_key="s3cret") as keyed:
        arm = await keyed.upload(two_link_urdf(name="keyed"))
        await keyed.delete(arm.id)


async def test_not_ready_and_payload_too_large(tmp_path: Any, registry: Registry) -> None:
    loading = create_app(Settings(data_dir=tmp_path), registry=Registry(tmp_path, ["ur5"]))
    async with _client(loading) as client:
        assert await client.ready() is False
        with pytest.raises(robodyn.NotReadyError) as err:
            await client.robot("ur5")
        assert isinstance(err.value, robodyn.ServiceUnavailableError)
        assert err.value.retry_after == 1.0
    small = create_app(Settings(data_dir=tmp_path, max_body_bytes=1024), registry=registry)
    async with _client(small) as client:
        with pytest.raises(robodyn.PayloadTooLargeError, match="1024 bytes"):
            await client.mass_matrix("ur5", np.full((100, 6), 0.123456789))
        assert (await client.mass_matrix("ur5", np.zeros(6))).shape == (6, 6)
