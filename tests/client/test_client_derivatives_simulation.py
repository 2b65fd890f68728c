"""Client methods of the derivatives, centroidal momentum, external forces, simulate and
joint-name inputs, sync and async, against the real app in process and in-process
Pinocchio; local input checks send nothing."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import httpx
import numpy as np
import pinocchio as pin
import pytest
import robodyn
from fastapi.testclient import TestClient
from robodyn import AsyncClient, Client

from service.api.quantities import SPECS
from tests.client.helpers import ATOL, RTOL, Reference


@pytest.fixture(scope="module")
def client(app: Any) -> Iterator[Client]:
    with TestClient(app, base_url="http://robodyn.test") as http, Client(http_client=http) as c:
        yield c


def close(got: Any, want: np.ndarray) -> None:
    assert isinstance(got, np.ndarray) and got.dtype == np.float64 and got.shape == want.shape
    np.testing.assert_allclose(got, want, rtol=RTOL, atol=ATOL)


def _derivatives(model: Any, fn: Any, *arrays: np.ndarray) -> list[np.ndarray]:
    data = model.createData()
    out = [
        [np.array(x, copy=True) for x in fn(model, data, *row)] for row in zip(*arrays, strict=True)
    ]
    return [np.array(x) for x in zip(*out, strict=True)]


@pytest.mark.parametrize("robot_id", ["panda", "talos"])
def test_derivatives_equal_pinocchio(client: Client, reference: Reference, robot_id: str) -> None:
    model, s = reference.model(robot_id), reference.states(robot_id, 3, seed=1)
    got = client.inverse_dynamics_derivatives(robot_id, s["q"], s["v"], s["a"])
    assert isinstance(got, robodyn.InverseDynamicsDerivatives)
    dq, dv, _ = _derivatives(model, pin.computeRNEADerivatives, s["q"], s["v"], s["a"])
    close(got.dtau_dq, dq)
    close(got.dtau_dv, dv)
    close(got.dtau_da, reference.mass_matrix(robot_id, s["q"]))
    single = client.inverse_dynamics_derivatives(robot_id, s["q"][1], s["v"][1], s["a"][1])
    close(single.dtau_dq, dq[1])
    da_dq, da_dv, da_dtau = client.forward_dynamics_derivatives(robot_id, s["q"], s["v"], s["tau"])
    want = _derivatives(model, pin.computeABADerivatives, s["q"], s["v"], s["tau"])
    np.testing.assert_allclose(da_dq, want[0], rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(da_dv, want[1], rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(
        da_dtau @ reference.mass_matrix(robot_id, s["q"]),
        np.broadcast_to(np.eye(model.nv), da_dtau.shape),
        atol=1e-8,
    )


def test_centroidal_equals_pinocchio(client: Client, reference: Reference) -> None:
    model, s = reference.model("talos"), reference.states("talos", 2, seed=2)
    got = client.centroidal("talos", s["q"], s["v"])
    assert isinstance(got, robodyn.Centroidal) and got.momentum_matrix.shape == (2, 6, model.nv)
    data = model.createData()
    for i in range(2):
        A = pin.ccrba(model, data, s["q"][i], s["v"][i])
        close(got.momentum_matrix[i], A)
        close(got.momentum[i], data.hg.vector)
        close(got.center_of_mass[i], data.com[0])
    momentum, matrix, com = client.centroidal("talos", s["q"][0], s["v"][0])
    assert momentum.shape == (6,) and matrix.shape == (6, model.nv) and com.shape == (3,)


def test_external_forces(client: Client, reference: Reference) -> None:
    model, s = reference.model("panda"), reference.states("panda", 2, seed=3)
    w = np.array([3.0, -2.0, 5.0, 0.2, 0.1, -0.3])
    forces = [{"frame": "panda_hand_tcp", "wrench": w, "reference_frame": "local"}]
    free = client.inverse_dynamics("panda", s["q"], s["v"], s["a"])
    loaded = client.inverse_dynamics("panda", s["q"], s["v"], s["a"], external_forces=forces)
    fid = model.getFrameId("panda_hand_tcp")
    for i in range(2):
        J = pin.computeFrameJacobian(model, model.createData(), s["q"][i], fid, pin.LOCAL)
        np.testing.assert_allclose(loaded[i] - free[i], -J.T @ w, atol=1e-9)
    back = client.forward_dynamics("panda", s["q"], s["v"], loaded, external_forces=forces)
    np.testing.assert_allclose(back, s["a"], atol=1e-7)
    with pytest.raises(robodyn.UnknownFrameError) as raised:
        client.inverse_dynamics(
            "panda",
            s["q"][0],
            s["v"][0],
            s["a"][0],
            external_forces=[{"frame": "nope", "wrench": w}],
        )
    assert isinstance(raised.value, LookupError) and raised.value.status == 422


def test_simulate(client: Client, reference: Reference) -> None:
    model = reference.model("ur5")
    q0 = np.array([0.0, -1.0, 1.0, 0.0, 0.5, 0.0])
    traj = client.simulate("ur5", q0, np.zeros(6), dt=1e-3, steps=200, integrator="rk4")
    assert isinstance(traj, robodyn.Trajectory)
    assert traj.q.shape == (201, 6) and traj.v.shape == (201, 6) and traj.t.shape == (201,)
    np.testing.assert_allclose(traj.mechanical_energy, traj.mechanical_energy[0], rtol=1e-8)
    target = q0 + 0.2
    M = np.diag(pin.crba(model, model.createData(), target))
    pd = client.simulate(
        "ur5",
        np.stack([q0, q0 - 0.1]),
        np.zeros((2, 6)),
        dt=1e-3,
        steps=2000,
        controller={
            "type": "pd",
            "kp": 100 * M,
            "kd": 20 * M,
            "q_target": target,
            "gravity_compensation": True,
        },
    )
    assert pd.q.shape == (2, 2001, 6) and pd.t.shape == (2, 2001)
    np.testing.assert_allclose(pd.q[:, -1], np.stack([target, target]), atol=1e-4)
    scheduled = client.simulate("ur5", q0, np.zeros(6), dt=1e-3, steps=3, tau=np.ones((3, 6)))
    constant = client.simulate("ur5", q0, np.zeros(6), dt=1e-3, steps=3, tau=np.ones(6))
    np.testing.assert_array_equal(scheduled.q, constant.q)


def test_joint_name_inputs(client: Client, reference: Reference) -> None:
    info = client.robot("talos")
    s = reference.states("talos", 2, seed=4)

    def by_name(x: np.ndarray, space: str) -> dict[str, Any]:
        out = {}
        for j in reversed(info.joints):
            start, size = (j.idx_q, j.nq) if space == "q" else (j.idx_v, j.nv)
            out[j.name] = x[start : start + size] if size > 1 else float(x[start])
        return out

    want = client.inverse_dynamics("talos", s["q"][0], s["v"][0], s["a"][0])
    got = client.inverse_dynamics(
        "talos", by_name(s["q"][0], "q"), by_name(s["v"][0], "v"), s["a"][0]
    )
    np.testing.assert_array_equal(got, want)
    batch = client.gravity("talos", [by_name(s["q"][0], "q"), by_name(s["q"][1], "q")])
    np.testing.assert_array_equal(batch, client.gravity("talos", s["q"]))
    with pytest.raises(robodyn.DimensionMismatchError) as raised:
        client.gravity("talos", {"root_joint": s["q"][0][:7]})
    assert "missing" in raised.value.body and len(raised.value.body["missing"]) > 0


class _Recorder:
    def __init__(self) -> None:
        self.requests: list[httpx.Request] = []

    def __call__(self, request: httpx.Request) -> httpx.Response:
        self.requests.append(request)
        vector: list[Any] = [0.0]
        q = json.loads(request.content)["q"]
        if isinstance(q, list) and isinstance(q[0], list):  # a batch
            vector = [[0.0]]
        return httpx.Response(
            200,
            json={
                "tau": vector,
                "a": vector,
                "t": [0.0],
                "q": [[0.0]],
                "v": [[0.0]],
                "mechanical_energy": [0.0],
                "dtau_dq": [[0.0]],
                "dtau_dv": [[0.0]],
                "dtau_da": [[1.0]],
            },
        )


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (
            lambda c: c.inverse_dynamics("r", [0], [0], [0], external_forces=[{"frame": "f"}]),
            "needs 'frame' and 'wrench'",
        ),
        (
            lambda c: c.inverse_dynamics(
                "r", [0], [0], [0], external_forces=[{"frame": "f", "wrench": [0] * 5}]
            ),
            "6 entries",
        ),
        (
            lambda c: c.inverse_dynamics(
                "r",
                [0],
                [0],
                [0],
                external_forces=[{"frame": "f", "wrench": [0] * 6, "reference_frame": "body"}],
            ),
            "one of",
        ),
        (
            lambda c: c.inverse_dynamics("r", [0], [0], [0], external_forces={"frame": "f"}),
            "list of",
        ),
        (lambda c: c.simulate("r", [0], [0], dt=0, steps=1), "dt must be"),
        (lambda c: c.simulate("r", [0], [0], dt=1e-3, steps=0), "steps must be"),
        (lambda c: c.simulate("r", [0], [0], dt=1e-3, steps=1, tau=[0], controller={}), "not both"),
        (lambda c: c.simulate("r", [0], [0], dt=1e-3, steps=1, integrator="euler"), "one of"),
        (
            lambda c: c.simulate(
                "r",
                [0],
                [0],
                dt=1e-3,
                steps=1,
                controller={"type": "pd", "kp": float("nan"), "kd": 1.0, "q_target": [0.0]},
            ),
            "finite",
        ),
        (lambda c: c.gravity("r", {"j": float("nan")}), "finite"),
        (lambda c: c.gravity("r", {1: 0.0}), "joint names"),
        (lambda c: c.gravity("r", {"j": "x"}), "real numbers"),
        (lambda c: c.inverse_dynamics("r", {"j": 0.0}, [[0.0]], [[0.0]]), "mix single states"),
    ],
)
def test_bad_options_raise_input_error_and_send_nothing(call: Any, match: str) -> None:
    recorder = _Recorder()
    http = httpx.Client(transport=httpx.MockTransport(recorder), base_url="http://mock")
    with Client(http_client=http) as c, pytest.raises(robodyn.InputError, match=match):
        call(c)
    assert recorder.requests == []


def test_request_bodies_validate_against_the_server_schemas() -> None:
    recorder = _Recorder()
    http = httpx.Client(transport=httpx.MockTransport(recorder), base_url="http://mock")
    w = np.arange(6.0)
    with Client(http_client=http) as c:
        c.inverse_dynamics(
            "r",
            [0.0],
            [0.0],
            [0.0],
            external_forces=[{"frame": "f", "wrench": w, "reference_frame": "world"}],
        )
        c.forward_dynamics(
            "r",
            [[0.0]],
            [[0.0]],
            [[0.0]],
            external_forces=[{"frame": "f", "wrench": np.stack([w])}],
        )
        c.simulate("r", {"j": 0.0}, [0.0], dt=1e-3, steps=2, tau=np.zeros((2, 1)), integrator="rk4")
        c.simulate(
            "r",
            [0.0],
            [0.0],
            dt=1e-3,
            steps=2,
            controller={
                "type": "pd",
                "kp": np.ones(1),
                "kd": 2,
                "q_target": {"j": [1.0]},
                "gravity_compensation": True,
            },
        )
        c.inverse_dynamics_derivatives("r", {"j": 0.0}, {"j": [0.0]}, [0.0])
    paths = [
        "inverse-dynamics",
        "forward-dynamics",
        "simulate",
        "simulate",
        "inverse-dynamics-derivatives",
    ]
    for request, path in zip(recorder.requests, paths, strict=True):
        assert request.url.path.endswith("/" + path)
        # strict: no extra or mistyped field
        SPECS[path].request.model_validate_json(request.content)
    assert json.loads(recorder.requests[3].content)["controller"]["kd"] == 2.0


@pytest.mark.anyio
async def test_async_client_has_the_same_answers(
    app: Any, client: Client, reference: Reference
) -> None:
    s = reference.states("panda", 2, seed=5)
    forces = [{"frame": "panda_hand", "wrench": np.ones(6)}]
    async with (
        httpx.AsyncClient(
            transport=httpx.ASGITransport(app=app), base_url="http://robodyn.test"
        ) as http,
        AsyncClient(http_client=http) as aclient,
    ):
        pairs = [
            (
                await aclient.inverse_dynamics_derivatives("panda", s["q"], s["v"], s["a"]),
                client.inverse_dynamics_derivatives("panda", s["q"], s["v"], s["a"]),
            ),
            (
                await aclient.forward_dynamics_derivatives("panda", s["q"], s["v"], s["tau"]),
                client.forward_dynamics_derivatives("panda", s["q"], s["v"], s["tau"]),
            ),
            (
                await aclient.centroidal("panda", s["q"], s["v"]),
                client.centroidal("panda", s["q"], s["v"]),
            ),
            (
                await aclient.simulate("panda", s["q"], s["v"], dt=1e-3, steps=5),
                client.simulate("panda", s["q"], s["v"], dt=1e-3, steps=5),
            ),
            (
                (
                    await aclient.inverse_dynamics(
                        "panda", s["q"], s["v"], s["a"], external_forces=forces
                    ),
                ),
                (client.inverse_dynamics("panda", s["q"], s["v"], s["a"], external_forces=forces),),
            ),
            (
                (
                    await aclient.forward_dynamics(
                        "panda", s["q"], s["v"], s["tau"], external_forces=forces
                    ),
                ),
                (
                    client.forward_dynamics(
                        "panda", s["q"], s["v"], s["tau"], external_forces=forces
                    ),
                ),
            ),
        ]
    for got, want in pairs:
        assert type(got) is type(want)
        for g, w in zip(got, want, strict=True):
            np.testing.assert_array_equal(g, w)


def test_end_to_end_against_a_real_server(server: str, reference: Reference) -> None:
    """Every new method over a real socket to `python -m service`, single state and batch."""
    s = reference.states("talos", 2, seed=6)
    with Client(server) as c:
        for q, v, a in ((s["q"], s["v"], s["a"]), (s["q"][0], s["v"][0], s["a"][0])):
            dtau = c.inverse_dynamics_derivatives("talos", q, v, a)
            M = reference.mass_matrix("talos", np.atleast_2d(q))
            close(dtau.dtau_da, M if q.ndim == 2 else M[0])
            da = c.forward_dynamics_derivatives("talos", q, v, a)
            assert da.da_dq.shape == dtau.dtau_dq.shape
            h = c.centroidal("talos", q, v)
            assert h.momentum.shape[-1] == 6
            forces = [{"frame": "imu_link", "wrench": np.ones(6), "reference_frame": "world"}]
            tau = c.inverse_dynamics("talos", q, v, a, external_forces=forces)
            close(c.forward_dynamics("talos", q, v, tau, external_forces=forces), a)
            traj = c.simulate("talos", q, v, dt=1e-3, steps=10, integrator="rk4")
            assert traj.q.shape[-2:] == (11, reference.model("talos").nq)
        by_name = {j.name: 0.1 for j in reversed(c.robot("ur5").joints)}
        np.testing.assert_array_equal(c.gravity("ur5", by_name), c.gravity("ur5", [0.1] * 6))
