"""Joint limits in `RobotInfo.joints`: one number for a 1-DoF joint (`effort_limit == 87.0`,
not `(87.0,)`), tuples for multi-DoF joints, None where unbounded — read from the server's
per-joint lists and equal to the model's own limits."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from robodyn import Client
from robodyn.models import JointInfo


@pytest.fixture(scope="module")
def client(app: Any) -> Iterator[Client]:
    with TestClient(app) as http, Client(http_client=http) as c:
        yield c


def test_a_1_dof_joint_has_numbers_for_limits(client: Client, registry: Any) -> None:
    model = registry.get("ur5").model
    elbow = client.robot("ur5").joint("elbow_joint")
    jid = model.getJointId("elbow_joint")
    assert isinstance(elbow.effort_limit, float) and isinstance(elbow.velocity_limit, float)
    assert elbow.effort_limit == model.effortLimit[model.idx_vs[jid]]
    assert elbow.velocity_limit == model.velocityLimit[model.idx_vs[jid]]
    assert elbow.lower == model.lowerPositionLimit[model.idx_qs[jid]]
    assert elbow.upper == model.upperPositionLimit[model.idx_qs[jid]]
    assert elbow.armature == model.armature[model.idx_vs[jid]]


def test_a_continuous_joint_has_no_position_limit(client: Client) -> None:
    info = client.robot("double_pendulum_continuous")
    joint = next(j for j in info.joints if j.type == "continuous")
    assert (joint.nq, joint.nv) == (2, 1)
    assert joint.lower is None and joint.upper is None
    assert joint.effort_limit is None or isinstance(joint.effort_limit, float)


def test_a_multi_dof_joint_keeps_tuples(client: Client) -> None:
    root = client.robot("talos").joints[0]
    assert root.nv == 6 and root.nq == 7
    assert isinstance(root.effort_limit, tuple) and len(root.effort_limit) == 6
    assert isinstance(root.lower, tuple) and len(root.lower) == 7
    assert isinstance(root.armature, tuple) and len(root.armature) == 6


def test_limits_are_read_from_the_server_lists() -> None:
    one = {
        "name": "j",
        "type": "revolute",
        "idx_q": 0,
        "nq": 1,
        "idx_v": 0,
        "nv": 1,
        "lower": [-1.5],
        "upper": [None],
        "velocity_limit": [3.0],
        "effort_limit": [87.0],
        "armature": [0.1],
    }
    joint = JointInfo.from_json(one)
    assert (joint.lower, joint.upper, joint.velocity_limit, joint.effort_limit, joint.armature) == (
        -1.5,
        None,
        3.0,
        87.0,
        0.1,
    )
    planar = {
        **one,
        "type": "planar",
        "nq": 4,
        "nv": 3,
        "lower": [None] * 4,
        "upper": [1.0, 1.0, None, None],
        "velocity_limit": [1.0, 2.0, 3.0],
        "effort_limit": [None, 5.0, 6.0],
        "armature": [0.0, 0.0, 0.0],
    }
    joint = JointInfo.from_json(planar)
    assert joint.upper == (1.0, 1.0, None, None) and joint.effort_limit == (None, 5.0, 6.0)
    assert joint.armature == (0.0, 0.0, 0.0)
