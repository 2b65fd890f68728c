"""Client methods of the Lagrangian, frame and task-space quantities — mass_matrix_inverse,
energy, center_of_mass, jacobian, operational_space, inertias — sync against a real server and
async against the app in process, single and batch, checked against in-process Pinocchio; their
errors and local input checks."""

from __future__ import annotations

import contextlib
import dataclasses
import json
from collections.abc import AsyncIterator, Iterator
from typing import Any

import httpx
import numpy as np
import pinocchio as pin
import pytest
import robodyn
from robodyn import AsyncClient, Client, results
from robodyn._calls import BUILDERS

from robots import CATALOG_DIR
from service.api.quantities import SPECS
from service.api.schemas.body_inertias import BodyInertia, Inertias
from tests.client.helpers import API_KEY, CATALOG, Reference
from tests.operational_space_reference import RF, pinocchio_operational_space

# (frame, task, damping) per robot: the 2-joint arms need damping for a 3-row task
TASKS = {
    "ur5": ("tool0", "full", 0.0),
    "panda": ("panda_hand_tcp", "full", 0.0),
    "talos": ("arm_left_7_link", "full", 0.0),
    "planar_arm": ("tip", "linear", 0.1),
    "double_pendulum_continuous": ("link2", "linear", 0.1),
}
N = 3


def _close(got: Any, want: Any, rtol: float = 1e-9) -> None:
    assert isinstance(got, np.ndarray) and got.dtype == np.float64
    want = np.asarray(want)
    assert got.shape == want.shape
    scale = max(1.0, float(np.abs(want).max(initial=0.0)))
    np.testing.assert_allclose(got, want, rtol=rtol, atol=rtol * scale)


def expected(
    reference: Reference, robot_id: str, method: str, q: np.ndarray, v: np.ndarray
) -> dict[str, np.ndarray]:
    """What each method must give, per state (batch axis first), from Pinocchio in process."""
    model = reference.model(robot_id)
    data = model.createData()
    frame, task, damping = TASKS[robot_id]
    fid = model.getFrameId(frame)
    rows: list[dict[str, Any]] = []
    for qi, vi in zip(q, v, strict=True):
        if method == "mass_matrix_inverse":
            M = pin.crba(model, data, qi)
            rows.append({"": np.linalg.inv(np.triu(M) + np.triu(M, 1).T)})
        elif method == "energy":
            rows.append(
                {
                    "kinetic_energy": pin.computeKineticEnergy(model, data, qi, vi),
                    "potential_energy": pin.computePotentialEnergy(model, data, qi),
                }
            )
            rows[-1]["mechanical_energy"] = sum(rows[-1].values())
        elif method == "center_of_mass":
            rows.append(
                {
                    "position": pin.centerOfMass(model, data, qi).copy(),
                    "jacobian": pin.jacobianCenterOfMass(model, data, qi).copy(),
                }
            )
            rows[-1]["velocity"] = rows[-1]["jacobian"] @ vi
        elif method == "jacobian":
            pin.computeJointJacobiansTimeVariation(model, data, qi, vi)
            pin.updateFramePlacements(model, data)
            rows.append(
                {
                    "jacobian": pin.getFrameJacobian(model, data, fid, RF["local"]).copy(),
                    "jacobian_time_variation": pin.getFrameJacobianTimeVariation(
                        model, data, fid, RF["local"]
                    ).copy(),
                }
            )
        elif method == "operational_space":
            rows.append(pinocchio_operational_space(model, qi, vi, frame, "world", task, damping))
    return {k: np.array([r[k] for r in rows]) for k in rows[0]}


def call_args(
    robot_id: str, method: str, q: np.ndarray, v: np.ndarray
) -> tuple[tuple[Any, ...], dict[str, Any]]:
    frame, task, damping = TASKS[robot_id]
    if method == "mass_matrix_inverse":
        return (robot_id, q), {}
    if method == "energy":
        return (robot_id, q, v), {}
    if method == "center_of_mass":
        return (robot_id, q, v), {}
    if method == "jacobian":
        return (robot_id, q, frame), {"reference_frame": "local", "v": v}
    return (robot_id, q, frame), {
        "v": v,
        "reference_frame": "world",
        "task": task,
        "damping": damping,
    }


def check(got: Any, want: dict[str, np.ndarray], index: int | None) -> None:
    """`got` (a result object or an array) equals `want` (batch axis first) at `index`, or
    over the whole batch when `index` is None."""
    pick = (lambda x: x) if index is None else (lambda x: x[index])
    if isinstance(got, np.ndarray):
        _close(got, pick(want[""]), 1e-8)
        return
    assert dataclasses.is_dataclass(got)
    for key, value in want.items():
        part = getattr(got, key)
        if index is not None and np.ndim(pick(value)) == 0:
            assert isinstance(part, float)
            part = np.asarray(part)
        _close(part, pick(value), 1e-8)


METHODS = ["mass_matrix_inverse", "energy", "center_of_mass", "jacobian", "operational_space"]


# -- async, against the app in process ------------------------------------------------------


@pytest.fixture
async def aclient(app: Any) -> AsyncIterator[AsyncClient]:
    transport = httpx.ASGITransport(app=app)
    async with (
        httpx.AsyncClient(transport=transport, base_url="http://robodyn.test") as http,
        AsyncClient(http_client=http) as client,
    ):
        yield client


@pytest.mark.anyio
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("robot_id", CATALOG)
async def test_async_methods_equal_pinocchio_single_and_batch(
    aclient: AsyncClient, reference: Reference, robot_id: str, method: str
) -> None:
    states = reference.states(robot_id, N, seed=len(method))
    q, v = states["q"], states["v"]
    want = expected(reference, robot_id, method, q, v)
    args, kwargs = call_args(robot_id, method, q, v)
    check(await getattr(aclient, method)(*args, **kwargs), want, None)
    for i in range(N):
        args, kwargs = call_args(robot_id, method, q[i], v[i])
        check(await getattr(aclient, method)(*args, **kwargs), want, i)


@pytest.mark.anyio
async def test_async_inertias_and_errors(aclient: AsyncClient, registry: Any) -> None:
    inertias = await aclient.inertias("talos")
    model = registry.get("talos").model
    assert len(inertias) == model.njoints - 1
    assert inertias.total_mass == pytest.approx(pin.computeTotalMass(model), rel=1e-12)
    body = inertias["arm_left_4_joint"]
    np.testing.assert_allclose(
        body.center_of_mass, model.inertias[model.getJointId("arm_left_4_joint")].lever, atol=1e-15
    )
    with pytest.raises(robodyn.UnknownFrameError) as err:
        await aclient.jacobian("ur5", np.zeros(6), "gripper")
    assert "`frames` of GET /v1/robots/ur5" in err.value.detail
    with pytest.raises(robodyn.SingularConfigurationError):
        await aclient.operational_space("ur5", np.zeros(6), "tool0")
    with pytest.raises(robodyn.RobotNotFoundError):
        await aclient.inertias("nope")


# -- sync, against a real server ------------------------------------------------------------


@pytest.fixture(scope="module")
def client(server: str) -> Iterator[Client]:
    with Client(server) as c:
        yield c


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("robot_id", ["ur5", "talos", "planar_arm"])
def test_sync_methods_equal_pinocchio_single_and_batch(
    client: Client, reference: Reference, robot_id: str, method: str
) -> None:
    states = reference.states(robot_id, N, seed=7)
    q, v = states["q"], states["v"]
    want = expected(reference, robot_id, method, q, v)
    args, kwargs = call_args(robot_id, method, q, v)
    check(getattr(client, method)(*args, **kwargs), want, None)
    args, kwargs = call_args(robot_id, method, q[1], v[1])
    check(getattr(client, method)(*args, **kwargs), want, 1)


def test_sync_optional_parts_and_defaults(client: Client, reference: Reference) -> None:
    q = reference.states("ur5", 1, seed=3)["q"][0]
    com = client.center_of_mass("ur5", q)
    assert com.velocity is None and com.position.shape == (3,)
    jac = client.jacobian("ur5", q, "tool0")
    assert jac.jacobian_time_variation is None and jac.jacobian.shape == (6, 6)
    model = reference.model("ur5")
    default = pin.computeFrameJacobian(
        model, model.createData(), q, model.getFrameId("tool0"), RF["local_world_aligned"]
    )
    _close(jac.jacobian, default, 1e-12)  # local_world_aligned by default
    os = client.operational_space("ur5", q, "tool0", task="angular")
    assert os.coriolis is None and os.inertia.shape == (3, 3) and os.gravity.shape == (3,)
    _close(os.jacobian, default[3:], 1e-12)


def test_sync_inertias_of_the_cube(client: Client) -> None:
    # the catalog of the test server has no cube_pendulum: upload it
    with Client(client.base_url, api_key=API_KEY) as writer:
        robot = writer.upload(CATALOG_DIR / "textbook" / "cube_pendulum.urdf")
        try:
            inertias = client.inertias(robot.id)
            cube = inertias["cube"]
            assert (cube.joint, cube.links, cube.mass) == ("hinge", ("cube",), 2.4)
            np.testing.assert_allclose(
                cube.inertia_at_center_of_mass, 0.016 * np.eye(3), atol=1e-15
            )
            np.testing.assert_allclose(cube.inertia_at_joint[0], [0.136, -0.072, 0.144], atol=1e-15)
            assert inertias.total_mass == pytest.approx(3.9, abs=1e-15)
            assert [b.joint for b in inertias] == ["hinge", "swing"]
        finally:
            writer.delete(robot.id)


def test_sync_errors(client: Client) -> None:
    with pytest.raises(robodyn.UnknownFrameError) as err:
        client.operational_space("ur5", np.zeros(6), "gripper")
    assert isinstance(err.value, LookupError) and err.value.status == 422
    with pytest.raises(robodyn.SingularConfigurationError) as singular:
        client.operational_space("ur5", np.zeros((2, 6)), "tool0")
    assert singular.value.detail.startswith("state 0:") and "damping" in singular.value.detail
    assert singular.value.body["smallest_singular_value"] >= 0
    damped = client.operational_space("ur5", np.zeros((2, 6)), "tool0", damping=0.05)
    assert damped.inertia.shape == (2, 6, 6)
    with pytest.raises(robodyn.RobotNotFoundError):
        client.inertias("nope")


# -- local checks and the contract ----------------------------------------------------------


class Recorder:
    def __init__(self) -> None:
        self.requests: list[httpx.Request] = []

    def __call__(self, request: httpx.Request) -> httpx.Response:
        self.requests.append(request)
        return httpx.Response(200, json={})


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"task": "position"}, robodyn.InputError),
        ({"reference_frame": "WORLD"}, robodyn.InputError),
        ({"damping": -1.0}, robodyn.InputError),
        ({"damping": float("nan")}, robodyn.InputError),
        ({"damping": "0.1"}, robodyn.InputError),
        ({"damping": True}, robodyn.InputError),
    ],
)
def test_bad_options_raise_locally_and_send_nothing(kwargs: dict[str, Any], error: type) -> None:
    recorder = Recorder()
    http = httpx.Client(transport=httpx.MockTransport(recorder), base_url="http://mock")
    with Client(http_client=http) as c:
        with pytest.raises(error):
            c.operational_space("ur5", np.zeros(6), "tool0", **kwargs)
        with pytest.raises(TypeError):
            c.jacobian("ur5", np.zeros(6), 3)  # type: ignore[arg-type]
        with pytest.raises(robodyn.InputError):
            c.jacobian("ur5", np.zeros(6), "")
        with pytest.raises(robodyn.InputError):
            c.center_of_mass("ur5", np.zeros(6), np.zeros((2, 6)))  # mixed single and batch
    assert recorder.requests == []


def test_bodies_sent_validate_against_the_server_schemas() -> None:
    recorder = Recorder()
    http = httpx.Client(transport=httpx.MockTransport(recorder), base_url="http://mock")
    q, v = np.zeros(6), np.ones(6)
    sent = {
        "mass-matrix-inverse": lambda c: c.mass_matrix_inverse("r", q),
        "energy": lambda c: c.energy("r", q, v),
        "center-of-mass": lambda c: c.center_of_mass("r", q),
        "jacobian": lambda c: c.jacobian("r", q, "tool0", v=v, reference_frame="world"),
        "operational-space": lambda c: c.operational_space(
            "r", q, "tool0", v=v, task="linear", damping=0.1
        ),
    }
    with Client(http_client=http) as c:
        for path, send in sent.items():
            with contextlib.suppress(robodyn.ResponseFormatError):  # the mock answers {}
                send(c)
            request = recorder.requests[-1]
            assert request.url.path == f"/v1/robots/r/{path}"
            SPECS[path].request.model_validate(json.loads(request.content))  # strict


def test_result_fields_are_the_server_answer_fields() -> None:
    pairs = {
        results.Energy: "energy",
        results.CenterOfMass: "center-of-mass",
        results.FrameJacobian: "jacobian",
        results.OperationalSpace: "operational-space",
    }
    for cls, path in pairs.items():
        fields = {f.name for f in dataclasses.fields(cls)}
        assert fields == set(SPECS[path].answer.model_fields), cls
    body_fields = {f.name for f in dataclasses.fields(results.BodyInertia)} - {"raw"}
    assert body_fields == set(BodyInertia.model_fields)
    assert {f.name for f in dataclasses.fields(results.Inertias)} == set(Inertias.model_fields)
    call = BUILDERS["inertias"]("r")
    assert (call.method, call.route) == ("GET", "/v1/robots/{robot_id}/inertias")
