"""`joint_wrenches` of the client (sync and async) against the real app: τ and each joint's
transmitted wrench equal Pinocchio's RNEA and its data.f, for one state and a batch, with a
payload; and the trajectory check's sizing figures reach `JointCheck`."""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from robodyn import AsyncClient, Client, Payload

from tests.client.helpers import Reference


def _expected(
    model: Any, q: np.ndarray, v: np.ndarray, a: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    data = model.createData()
    tau = pin.rnea(model, data, q, v, a)
    return tau, np.array([data.f[j].vector for j in range(1, model.njoints)])


def test_joint_wrenches_one_state_and_a_batch(
    client: Client, registry: Any, reference: Reference
) -> None:
    model = registry.get("ur5").model
    s = reference.states("ur5", 3, seed=12)
    tau, wrenches = client.joint_wrenches("ur5", s["q"], s["v"], s["a"])
    assert tau.shape == (3, 6) and wrenches.shape == (3, 6, 6)
    for i in range(3):
        want_tau, want_wrenches = _expected(model, s["q"][i], s["v"][i], s["a"][i])
        np.testing.assert_allclose(tau[i], want_tau, atol=1e-9)
        np.testing.assert_allclose(wrenches[i], want_wrenches, atol=1e-9)
    one_tau, one = client.joint_wrenches("ur5", s["q"][0], s["v"][0], s["a"][0])
    assert one_tau.shape == (6,) and one.shape == (6, 6)
    np.testing.assert_allclose(one, wrenches[0], atol=1e-12)


@pytest.mark.anyio
async def test_async_joint_wrenches_with_a_payload(aclient: AsyncClient, registry: Any) -> None:
    model = pin.Model(registry.get("ur5").model)
    q, v, a = np.array([0.1, -1.0, 1.2, 0.3, -0.4, 0.5]), np.full(6, 0.2), np.full(6, -0.3)
    tool = model.frames[model.getFrameId("tool0")]
    model.inertias[tool.parentJoint] += tool.placement.act(
        pin.Inertia(2.0, np.array([0.0, 0.0, 0.05]), np.zeros((3, 3)))
    )
    tau, wrenches = await aclient.joint_wrenches(
        "ur5", q, v, a, payloads=[Payload("tool0", 2.0, center_of_mass=(0.0, 0.0, 0.05))]
    )
    want_tau, want_wrenches = _expected(model, q, v, a)
    np.testing.assert_allclose(tau, want_tau, atol=1e-9)
    np.testing.assert_allclose(wrenches, want_wrenches, atol=1e-9)


def test_the_check_reports_the_sizing_figures(client: Client) -> None:
    """The planar arm held horizontal: the RMS shoulder torque is the holding torque."""
    t = [0.0, 1.0, 2.0]
    q = np.zeros((3, 2))
    check = client.trajectory_check("planar_arm", t, q, v=np.zeros((3, 2)), a=np.zeros((3, 2)))
    shoulder = check.joints[0]
    assert shoulder.rms_effort == pytest.approx(9.81 * (2.0 * 1.0 + 1.5 * 1.7), rel=1e-12)
    assert shoulder.peak_power == 0.0 and shoulder.peak_bending_moment == pytest.approx(
        0.0, abs=1e-12
    )
    assert shoulder.peak_force == pytest.approx(3.5 * 9.81, rel=1e-12)
