"""The blocking Client against a real server (`python -m service` on a loopback port)."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest
import robodyn
from robodyn import Client

from tests.client.helpers import (
    API_KEY,
    ATOL,
    CATALOG,
    RTOL,
    Reference,
    free_port,
    two_link_urdf,
)

QUANTITIES = {
    "mass_matrix": ("q",),
    "gravity": ("q",),
    "coriolis": ("q", "v"),
    "nonlinear_effects": ("q", "v"),
    "inverse_dynamics": ("q", "v", "a"),
    "forward_dynamics": ("q", "v", "tau"),
}
README = Path(__file__).parents[2] / "clients" / "python" / "README.md"


@pytest.fixture(scope="module")
def client(server: str) -> Iterator[Client]:
    with Client(server) as c:
        yield c


def close(got: np.ndarray, want: np.ndarray) -> None:
    assert isinstance(got, np.ndarray) and got.shape == want.shape
    np.testing.assert_allclose(got, want, rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("quantity", list(QUANTITIES))
@pytest.mark.parametrize("robot_id", CATALOG)
def test_dynamics_equal_pinocchio_single_and_batch(
    client: Client, reference: Reference, robot_id: str, quantity: str
) -> None:
    states = reference.states(robot_id, 4, seed=7)
    inputs = [states[name] for name in QUANTITIES[quantity]]
    want = getattr(reference, quantity)(robot_id, *inputs)
    wants = want if isinstance(want, tuple) else (want,)

    batch = getattr(client, quantity)(robot_id, *inputs)
    single = getattr(client, quantity)(robot_id, *(x[2] for x in inputs))
    batch, single = (batch, single) if isinstance(want, tuple) else ((batch,), (single,))
    for got_batch, got_single, w in zip(batch, single, wants, strict=True):
        close(got_batch, w)
        close(got_single, w[2])


def test_equation_of_motion_holds_through_the_client(client: Client, reference: Reference) -> None:
    s = reference.states("talos", 5, seed=3)
    q, v, a = s["q"], s["v"], s["a"]
    M = client.mass_matrix("talos", q)
    C, Cv = client.coriolis("talos", q, v)
    g = client.gravity("talos", q)
    tau = client.inverse_dynamics("talos", q, v, a)
    np.testing.assert_allclose(tau, np.einsum("nij,nj->ni", M, a) + Cv + g, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(Cv, np.einsum("nij,nj->ni", C, v), rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(client.nonlinear_effects("talos", q, v), Cv + g, atol=1e-8)
    np.testing.assert_allclose(client.forward_dynamics("talos", q, v, tau), a, atol=1e-7)


def test_upload_closed_form_and_delete(server: str, reference: Reference) -> None:
    m1, m2, l1, l2, g0 = 2.0, 1.5, 0.6, 0.4, 9.81
    urdf = two_link_urdf(m1, m2, l1, l2, name="server_arm")
    with Client(server, api_key=API_KEY) as client:
        arm = client.upload(urdf, root_joint="fixed")
        try:
            assert arm.created is True and (arm.nq, arm.nv) == (2, 2)
            assert arm.total_mass == pytest.approx(m1 + m2)
            assert client.upload(urdf).id == arm.id  # idempotent, same content → same id
            q = np.array([0.4, -1.1])
            # Uniform rods about y: I = m l²/12 at the centre of mass, half way along.
            i1, i2, c2 = m1 * l1**2 / 12, m2 * l2**2 / 12, np.cos(q[1])
            m12 = i2 + m2 * (l2**2 / 4 + l1 * l2 / 2 * c2)
            M = [
                [i1 + i2 + m1 * l1**2 / 4 + m2 * (l1**2 + l2**2 / 4 + l1 * l2 * c2), m12],
                [m12, i2 + m2 * l2**2 / 4],
            ]
            np.testing.assert_allclose(client.mass_matrix(arm.id, q), M, rtol=1e-12)
            # Rotation about +y takes x to (cos, 0, −sin): height of a point at r is −r sin.
            g2 = -m2 * g0 * l2 / 2 * np.cos(q[0] + q[1])
            g1 = -(m1 * l1 / 2 + m2 * l1) * g0 * np.cos(q[0]) + g2
            np.testing.assert_allclose(client.gravity(arm.id, q), [g1, g2], rtol=1e-12)

            reference.add_urdf(arm.id, urdf)
            s = reference.states(arm.id, 3, seed=11)
            close(
                client.forward_dynamics(arm.id, s["q"], s["v"], s["tau"]),
                reference.forward_dynamics(arm.id, s["q"], s["v"], s["tau"]),
            )
        finally:
            client.delete(arm.id)
        assert arm.id not in client.robots()
        with pytest.raises(robodyn.RobotNotFoundError):
            client.robot(arm.id)


def test_uploads_need_the_api_key(server: str) -> None:
    for key in (None, "wrong-key"):
        with (
            Client(server, api_key=key) as client,
            pytest.raises(robodyn.UnauthorizedError, match="API key") as err,
        ):
            client.upload(two_link_urdf(name="denied"))
        assert isinstance(err.value, PermissionError) and err.value.status == 401
    with Client(server) as client, pytest.raises(robodyn.UnauthorizedError):
        client.delete("u-0123456789abcdef01234567")


def test_errors_from_the_real_server(client: Client) -> None:
    with pytest.raises(robodyn.DimensionMismatchError) as err:
        client.inverse_dynamics("ur5", np.zeros((2, 6)), np.zeros((2, 6)), np.zeros((2, 5)))
    assert err.value.status == 422 and "nv = 6" in err.value.detail
    assert err.value.body["type"] == "about:blank"
    with pytest.raises(robodyn.RobotNotFoundError, match="GET /v1/robots"):
        client.gravity("ur5 ", np.zeros(6))  # ids are exact; the space is sent quoted
    with pytest.raises(robodyn.InvalidConfigurationError, match="joint1"):
        client.gravity("double_pendulum_continuous", [1.0, 1.0, 1.0, 0.0])


def test_info_and_health(client: Client) -> None:
    assert client.health() == {"status": "ok"} and client.ready() is True
    robots = client.robots()
    assert {r.id: (r.nq, r.nv) for r in robots}["talos"] == (39, 38)
    pendulum = client.robot("double_pendulum_continuous")
    assert [(j.type, j.idx_q, j.nq, j.idx_v, j.nv) for j in pendulum.joints] == [
        ("continuous", 0, 2, 0, 1),
        ("continuous", 2, 2, 1, 1),
    ]
    np.testing.assert_array_equal(pendulum.neutral_configuration, [1.0, 0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="read-only"):
        pendulum.neutral_configuration[0] = 2.0


def test_connection_is_reused_and_closed(server: str) -> None:
    connections: list[object] = []
    with Client(server) as client:
        for _ in range(5):
            client.gravity("ur5", np.zeros(6))
            pool = client._http._transport._pool  # type: ignore[attr-defined]
            connections.extend(pool.connections)
        assert len(set(map(id, connections))) == 1, "one keep-alive connection for all calls"
    assert client._http.is_closed


def test_transport_failures_are_wrapped(server: str) -> None:
    with (
        Client(f"http://127.0.0.1:{free_port()}") as client,
        pytest.raises(robodyn.TransportError) as err,
    ):
        client.robots()
    assert isinstance(err.value.__cause__, httpx.ConnectError)
    assert not isinstance(err.value, robodyn.TimeoutError) and err.value.method == "GET"
    q = np.tile(np.r_[np.zeros(3), 0, 0, 0, 1, np.zeros(32)], (2000, 1))  # ~1.5 MB to parse
    with (
        Client(server, timeout=httpx.Timeout(10.0, read=0.001)) as client,
        pytest.raises(robodyn.TimeoutError) as timeout,
    ):
        client.gravity("talos", q)
    assert isinstance(timeout.value, TimeoutError)  # the builtin
    assert isinstance(timeout.value.__cause__, httpx.ReadTimeout)


def test_readme_example_runs(
    server: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    text = README.read_text()
    files = re.findall(r"<!-- file: (\S+) -->\n```\w+\n(.*?)```", text, re.S)
    examples = re.findall(r"<!-- example -->\n```python\n(.*?)```", text, re.S)
    assert files and examples
    for name, content in files:
        (tmp_path / name).write_text(content)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("ROBODYN_API_KEY", API_KEY)
    for code in examples:
        exec(compile(code.replace("http://127.0.0.1:8000", server), str(README), "exec"), {})
    out = capsys.readouterr().out
    assert "422 dimension_mismatch q has 5 entries" in out and "lists the valid ids" in out
