"""`payload_capacity` and `variant` of the client against the real app: answers equal the
in-process physics (single state, a batch, the binary form of a large batch, async), nulls
read as inf, and a variant answers as its parent carrying the payloads."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from robodyn import AsyncClient, CapacityMinimum, Client, InputError, Payload, PayloadCapacity

from service.dynamics.payload_capacity import capacity
from tests.client.helpers import Reference

TOOL = Payload("tool0", 3.0, center_of_mass=(0.0, 0.0, 0.05))
COM = [0.0, 0.01, 0.08]


@pytest.fixture(scope="module")
def client(app: Any) -> Iterator[Client]:
    with TestClient(app) as http, Client(http_client=http) as c:
        yield c


def _check(got: PayloadCapacity, want: Any, batched: bool) -> None:
    np.testing.assert_allclose(got.mass, want.mass if batched else want.mass[0], rtol=1e-12)
    np.testing.assert_allclose(
        got.mass_per_joint,
        want.mass_per_joint if batched else want.mass_per_joint[0],
        rtol=1e-12,
        atol=0,
    )
    np.testing.assert_allclose(
        got.tau, want.tau if batched else want.tau[0], rtol=1e-12, atol=1e-12
    )
    names = tuple(want.limiting_joint(i) for i in range(want.mass.shape[0]))
    assert got.limiting_joint == (names if batched else names[0])
    ranges = np.where(np.isinf(want.mass_range), np.inf, want.mass_range)
    if batched:
        np.testing.assert_allclose(got.mass_range, ranges, rtol=1e-12)
    else:
        expected = None if np.isnan(ranges[0, 0]) else tuple(ranges[0])
        assert got.mass_range == (pytest.approx(expected, rel=1e-12) if expected else None)


def test_single_state_and_batch_equal_the_physics(
    client: Client, registry: Any, reference: Reference
) -> None:
    ur5 = registry.get("ur5")
    s = reference.states("ur5", 30, seed=3)
    want = capacity(
        ur5, s["q"], "tool0", center_of_mass=COM, v=s["v"], a=s["a"], payloads=[TOOL.to_json()]
    )
    got = client.payload_capacity(
        "ur5", s["q"], "tool0", center_of_mass=COM, v=s["v"], a=s["a"], payloads=[TOOL]
    )
    _check(got, want, batched=True)
    low = int(np.argmin(want.mass))
    common = want.common_range()
    assert common is not None and common[1] is not None
    assert got.minimum == CapacityMinimum(
        float(want.mass[low]), low, want.limiting_joint(low), (common[0], common[1])
    )
    one = client.payload_capacity(
        "ur5", s["q"][0], "tool0", center_of_mass=COM, v=s["v"][0], a=s["a"][0], payloads=[TOOL]
    )
    assert isinstance(one.mass, float) and one.minimum is None
    _check(one, want, batched=False)
    # the shoulder pan never feels a mass on the vertical axis at rest: inf, not a number
    still = client.payload_capacity("ur5", np.zeros(6), "tool0")
    assert np.isinf(still.mass_per_joint[0])
    # no limit anywhere: the mass itself is inf, and nothing limits it
    free = client.payload_capacity("ur5", np.zeros(6), "tool0", effort_limits=np.zeros(6))
    assert free.mass == np.inf and free.limiting_joint is None


def test_a_large_batch_in_the_binary_form_gives_the_same_answer(
    client: Client, registry: Any, reference: Reference
) -> None:
    s = reference.states("panda", 2000, seed=5)
    got = client.payload_capacity("panda", s["q"], "panda_hand", v=s["v"], a=s["a"])
    want = capacity(registry.get("panda"), s["q"], "panda_hand", v=s["v"], a=s["a"])
    _check(got, want, batched=True)
    assert got.minimum is not None and got.minimum.state == int(np.argmin(want.mass))


@pytest.mark.anyio
async def test_async_payload_capacity_and_variant(aclient: AsyncClient, registry: Any) -> None:
    q = np.array([0.1, -1.0, 1.2, 0.3, -0.4, 0.5])
    got = await aclient.payload_capacity(
        "ur5",
        q,
        "tool0",
        effort_limits={
            "shoulder_pan_joint": 150.0,
            "shoulder_lift_joint": 150.0,
            "elbow_joint": 150.0,
            "wrist_1_joint": 28.0,
            "wrist_2_joint": 28.0,
            "wrist_3_joint": 28.0,
        },
    )
    _check(got, capacity(registry.get("ur5"), q[None], "tool0"), batched=False)
    # the counterweight: gravity alone over the shoulder's 45.26 N·m, the mass pulling back
    held = await aclient.payload_capacity(
        "ur5",
        [0.0, -0.3, 0.0, 0.0, 0.0, 0.0],
        "upper_arm_link",
        center_of_mass=[0.0, 0.0, -0.25],
        effort_limits=[150.0, 45.26, 150.0, 28.0, 28.0, 28.0],
    )
    assert held.mass_range == (pytest.approx(4.8313, abs=1e-4), held.mass)
    assert round(held.mass, 2) == 43.47
    info = await aclient.variant("ur5", payloads=[TOOL], name="async tool")
    assert info.parent == "ur5" and info.name == "async tool"


def test_a_variant_answers_as_its_parent_carrying_the_payloads(client: Client) -> None:
    info = client.variant(
        "ur5",
        payloads=[TOOL, {"frame": "wrist_1_link", "mass": 0.4}],
        locked_joints={"wrist_3_joint": 0.0},
    )
    assert info.created is not None and info.id.startswith("v-") and info.parent == "ur5"
    assert info.nv == 5 and info.modifications is not None
    assert [p["frame"] for p in info.modifications["payloads"]] == ["tool0", "wrist_1_link"]
    assert info.moving_mass == info.total_mass and info.fixed_mass == 4.0
    again = client.variant(
        "ur5",
        payloads=[{"frame": "wrist_1_link", "mass": 0.4}, TOOL],
        locked_joints={"wrist_3_joint": 0.0},
    )
    assert again.id == info.id and again.created is False
    q = np.array([0.1, -1.0, 1.2, 0.3, -0.4, 0.0])
    carried = client.gravity("ur5", q, payloads=[TOOL, {"frame": "wrist_1_link", "mass": 0.4}])
    np.testing.assert_allclose(client.gravity(info.id, q[:5]), carried[:5], rtol=1e-12, atol=1e-12)
    with pytest.raises(InputError, match="payloads, locked_joints, inertias or several"):
        client.variant("ur5")
    with pytest.raises(InputError, match="center_of_mass"):
        client.payload_capacity("ur5", q, "tool0", center_of_mass=[0, 0])
