"""The client's trajectory methods against the in-process computation: named results with
the same numbers, and the errors as their classes."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import robodyn
from fastapi.testclient import TestClient
from robodyn import AsyncClient, Client

from service.dynamics.trajectories import check_trajectory, retime

WAYPOINTS = np.random.default_rng(0).uniform(-2.0, 2.0, (3, 6))


@pytest.fixture(scope="module")
def client(app: Any) -> Iterator[Client]:
    with TestClient(app) as http, Client(http_client=http) as c:
        yield c


def test_a_long_check_goes_in_the_binary_form_with_its_times(app: Any, registry) -> None:
    n = 60_000  # irregular times: as text they would overflow the binary form's header
    t = np.cumsum(np.random.default_rng(4).uniform(0.9e-3, 1.1e-3, n))
    q = np.stack([0.4 * np.sin((j + 1) * 0.3 * t) for j in range(6)], axis=1)
    sent: list[str] = []
    with TestClient(app) as http:
        http.event_hooks["request"].append(lambda r: sent.append(r.headers["content-type"]))
        with Client(http_client=http) as client:
            result = client.trajectory_check("ur5", t, q, samples_per_interval=1)
    assert sent == [robodyn.binary.MEDIA_TYPE]
    expected = check_trajectory(registry.get("ur5"), t, q, samples_per_interval=1)
    np.testing.assert_array_equal(result.tau, expected.tau)
    assert result.feasible == expected.feasible


def test_trajectory_check_has_named_results(client: Client, registry) -> None:
    t = np.linspace(0.0, 1.0, 21)
    q = np.outer(np.sin(3.0 * t), [0.5, -1.0, 1.2, 0.4, -0.6, 0.9])
    result = client.trajectory_check("ur5", t, q, velocity_scale=0.5)
    expected = check_trajectory(registry.get("ur5"), t, q, velocity_scale=0.5)
    assert isinstance(result, robodyn.TrajectoryCheck) and result.feasible is expected.feasible
    np.testing.assert_allclose(result.tau, expected.tau, rtol=1e-12, atol=1e-12)
    assert result.joints[2].name == "elbow_joint"
    assert result.joints[2].velocity_ratio == expected.joints[2]["velocity_ratio"]
    assert [v._asdict() for v in result.violations] == expected.violations
    assert result.work.positive == expected.work["positive"]


def test_retime_has_named_results(client: Client, registry) -> None:
    result = client.retime("ur5", WAYPOINTS, effort_scale=0.9)
    expected = retime(registry.get("ur5"), WAYPOINTS, effort_scale=0.9)
    assert isinstance(result, robodyn.Retimed) and result.duration == expected.duration
    np.testing.assert_array_equal(result.q, expected.q)
    np.testing.assert_array_equal(result.tau, expected.tau)
    assert result.check.feasible and result.q.shape == (len(result.t), 6)


def test_errors_are_their_classes(client: Client) -> None:
    with pytest.raises(robodyn.InfeasiblePathError) as caught:
        client.retime("ur5", WAYPOINTS, effort_scale=0.3)
    assert caught.value.body["joint"] == "shoulder_lift_joint"
    with pytest.raises(robodyn.UnsupportedModelError):
        client.retime("talos", np.zeros((2, 39)))
    with pytest.raises(robodyn.InputError, match="strictly increasing"):
        client.trajectory_check("ur5", [0.0, 0.0], np.zeros((2, 6)))
    with pytest.raises(robodyn.InputError, match="> 0"):
        client.retime("ur5", WAYPOINTS, velocity_scale=0)


@pytest.mark.anyio
async def test_async_client_answers_the_same(aclient: AsyncClient, client: Client) -> None:
    result = await aclient.retime("ur5", WAYPOINTS, sample_dt=0.05)
    assert result.duration == client.retime("ur5", WAYPOINTS, sample_dt=0.05).duration
    t = np.linspace(0.0, 1.0, 5)
    check = await aclient.trajectory_check("ur5", t, np.zeros((5, 6)))
    assert check.feasible and check.tau.shape == (5, 6)


ACCELERATION = [3.0, None, 2.0, float("nan"), None, 1.5]  # None or NaN: no limit
AS_SENT = [3.0, None, 2.0, None, None, 1.5]


def test_acceleration_limits_and_boundary_are_sent(client: Client, registry) -> None:
    """The check's acceleration limits (None and NaN entries: none) and spline boundary, and
    retime's acceleration limits with None entries: the in-process answers."""
    t = np.linspace(0.0, 1.0, 21)
    q = np.outer(np.sin(3.0 * t), [0.5, -1.0, 1.2, 0.4, -0.6, 0.9])
    result = client.trajectory_check(
        "ur5", t, q, acceleration=ACCELERATION, boundary="clamped", velocity_scale=0.5
    )
    expected = check_trajectory(
        registry.get("ur5"), t, q, acceleration=AS_SENT, boundary="clamped", velocity_scale=0.5
    )
    np.testing.assert_allclose(result.tau, expected.tau, rtol=1e-12, atol=1e-12)
    assert [j._asdict() for j in result.joints] == expected.joints
    assert [v._asdict() for v in result.violations] == expected.violations
    assert "acceleration" in {v.kind for v in result.violations}
    timed = client.retime("ur5", WAYPOINTS, acceleration=np.array(ACCELERATION))
    assert timed.duration == retime(registry.get("ur5"), WAYPOINTS, acceleration=AS_SENT).duration
    assert timed.check.joints[1].acceleration_limit is None
    with pytest.raises(robodyn.InputError, match="boundary must be one of"):
        client.trajectory_check("ur5", t, q, boundary="periodic")
    with pytest.raises(robodyn.InputError, match=r"acceleration\[1\]"):
        client.retime("ur5", WAYPOINTS, acceleration=[1.0, -1.0, 1, 1, 1, 1])


@pytest.mark.anyio
async def test_async_client_sends_acceleration_limits_and_boundary(
    aclient: AsyncClient, client: Client
) -> None:
    t = np.linspace(0.0, 1.0, 21)
    q = np.outer(np.sin(3.0 * t), [0.5, -1.0, 1.2, 0.4, -0.6, 0.9])
    options: dict[str, Any] = {"acceleration": ACCELERATION, "boundary": "natural"}
    result = await aclient.trajectory_check("ur5", t, q, **options)
    same = client.trajectory_check("ur5", t, q, **options)
    np.testing.assert_array_equal(result.tau, same.tau)
    assert result.joints == same.joints and result.violations == same.violations
    assert result.joints[0].acceleration_limit == 3.0
    timed = await aclient.retime("ur5", WAYPOINTS, acceleration=ACCELERATION, sample_dt=0.05)
    assert (
        timed.duration
        == client.retime("ur5", WAYPOINTS, acceleration=ACCELERATION, sample_dt=0.05).duration
    )
