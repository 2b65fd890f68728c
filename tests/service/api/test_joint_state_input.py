"""A ROS sensor_msgs/JointState as JSON is a joint-space input (q its positions, v its
velocities, τ its efforts), checked against Pinocchio in-process; a joint named twice — in a
JointState or as a key repeated in a name-keyed object — is a 422 naming it."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

from tests.helpers import random_state
from tests.service.api.problems.test_errors import assert_problem

HEADER = {"seq": 3, "stamp": {"secs": 1700000000, "nsecs": 5}, "frame_id": ""}


def joint_state(
    info: dict, q: np.ndarray, v: np.ndarray, tau: np.ndarray, order: np.ndarray | None = None
) -> dict:
    """What rosbridge (or json.dumps of the message) gives for a robot of 1-dof joints."""
    joints = [
        info["joints"][i] for i in (order if order is not None else range(len(info["joints"])))
    ]
    return {
        "header": HEADER,
        "name": [j["name"] for j in joints],
        "position": [float(q[j["idx_q"]]) for j in joints],
        "velocity": [float(v[j["idx_v"]]) for j in joints],
        "effort": [float(tau[j["idx_v"]]) for j in joints],
    }


@pytest.fixture(scope="module")
def ur5(catalog_registry):
    robot = catalog_registry.catalog["ur5"]
    return robot.model, robot.info()


def test_a_joint_state_is_q_v_and_tau_as_pinocchio_computes_them(api, ur5):
    model, info = ur5
    rng = np.random.default_rng(7)
    q, v, tau = random_state(model, rng)
    message = joint_state(info, q, v, tau, order=rng.permutation(len(info["joints"])))
    data = model.createData()
    r = api.post(
        "/v1/robots/ur5/forward-dynamics", json={"q": message, "v": message, "tau": message}
    )
    assert r.status_code == 200, r.text
    np.testing.assert_allclose(r.json()["a"], pin.aba(model, data, q, v, tau), atol=1e-9)
    r = api.post("/v1/robots/ur5/gravity", json={"q": message})
    np.testing.assert_allclose(
        r.json()["gravity"], pin.computeGeneralizedGravity(model, data, q), atol=1e-9
    )


def test_a_list_of_joint_states_is_a_batch(api, ur5):
    model, info = ur5
    rng = np.random.default_rng(8)
    states = [random_state(model, rng) for _ in range(3)]
    messages = [joint_state(info, q, v, a) for q, v, a in states]
    r = api.post("/v1/robots/ur5/nonlinear-effects", json={"q": messages, "v": messages})
    assert r.status_code == 200, r.text
    data = model.createData()
    expected = [pin.nonLinearEffects(model, data, q, v) for q, v, _ in states]
    np.testing.assert_allclose(r.json()["nonlinear_effects"], expected, atol=1e-9)


def test_a_joint_state_without_some_joints_needs_fill(api, ur5):
    model, info = ur5
    q = pin.neutral(model) + 0.3
    message = joint_state(info, q, np.zeros(6), np.zeros(6))
    partial = {
        key: value[:4] if isinstance(value, list) else value for key, value in message.items()
    }
    problem = assert_problem(
        api.post("/v1/robots/ur5/gravity", json={"q": partial}), 422, "dimension_mismatch"
    )
    assert problem["missing"] == ["wrist_2_joint", "wrist_3_joint"]
    r = api.post("/v1/robots/ur5/gravity", json={"q": partial, "fill": "neutral"})
    assert r.status_code == 200, r.text
    filled = np.concatenate([q[:4], pin.neutral(model)[4:]])
    np.testing.assert_allclose(
        r.json()["gravity"],
        pin.computeGeneralizedGravity(model, model.createData(), filled),
        atol=1e-9,
    )


def test_simulate_takes_a_joint_state_as_its_torque(api, ur5):
    model, info = ur5
    q, v = pin.neutral(model), np.zeros(6)
    tau = np.linspace(-1, 1, 6)
    message = joint_state(info, q, v, tau, order=np.arange(6)[::-1])
    body = {"q": q.tolist(), "v": v.tolist(), "dt": 1e-3, "steps": 2}
    by_state = api.post("/v1/robots/ur5/simulate", json={**body, "tau": message})
    by_array = api.post("/v1/robots/ur5/simulate", json={**body, "tau": tau.tolist()})
    assert by_state.status_code == 200, by_state.text
    assert by_state.json() == by_array.json()


@pytest.mark.parametrize(
    ("body", "code", "fragment"),
    [
        ({"position": [0.0] * 6}, "dimension_mismatch", "unknown names: position"),  # no names
        ({"position": [0.0] * 5}, "dimension_mismatch", "5 for 6 names"),
        ({"position": [0.0] * 6, "name": "twice"}, "validation_error", "twice"),
        ({"position": [0.0] * 6, "velocity": ["fast"] * 6}, "validation_error", "velocity[0]"),
    ],
)
def test_a_wrong_joint_state_is_a_422_naming_what(api, ur5, body, code, fragment):
    _, info = ur5
    names = [j["name"] for j in info["joints"]]
    message = {"name": names, **body}
    if body.get("name") == "twice":
        message["name"] = [*names[:5], names[0]]
    elif "name" not in body and list(body) == ["position"] and len(body["position"]) == 6:
        message.pop("name")
    problem = assert_problem(api.post("/v1/robots/ur5/gravity", json={"q": message}), 422, code)
    assert fragment in problem["detail"], problem


def test_acceleration_is_not_taken_from_a_joint_state(api, ur5):
    model, info = ur5
    message = joint_state(info, pin.neutral(model), np.zeros(6), np.zeros(6))
    problem = assert_problem(
        api.post(
            "/v1/robots/ur5/inverse-dynamics", json={"q": message, "v": message, "a": message}
        ),
        422,
        "validation_error",
    )
    assert problem["detail"].startswith("a cannot be given as a JointState")


@pytest.mark.parametrize("path", ["gravity", "stream"])
def test_a_joint_named_twice_in_a_name_keyed_object_is_a_422(api, ur5, path):
    """JSON parsers keep the last of two equal keys: the request was silently computed with
    the second value."""
    _, info = ur5
    members = ", ".join(f'"{j["name"]}": 0.1' for j in info["joints"])
    text = f'{{"q": {{{members}, "elbow_joint": 0.5}}}}'
    if path == "stream":
        with api.websocket_connect("/v1/robots/ur5/stream") as ws:
            ws.send_text(text[:-1] + ', "quantity": "gravity"}')
            problem = json.loads(ws.receive_text())
    else:
        problem = assert_problem(
            api.post(
                "/v1/robots/ur5/gravity", content=text, headers={"content-type": "application/json"}
            ),
            422,
            "validation_error",
        )
    assert problem["code"] == "validation_error"
    assert "'elbow_joint' is given twice" in problem["detail"]


def test_keys_repeated_outside_name_keyed_inputs_are_not_scanned(api):
    """Plain-array bodies pay no second parse (JSON keeps the last `q`, as a JSON parser does)."""
    text = '{"q": [0, 0, 0, 0, 0, 0], "q": [0, -1, 1, 0, 0, 0]}'
    r = api.post(
        "/v1/robots/ur5/gravity", content=text, headers={"content-type": "application/json"}
    )
    assert r.status_code == 200


def test_joints_called_name_and_position_are_still_keyed_by_name():
    """An object whose keys look like a JointState's but whose values are joint values (a
    robot with joints called "name" and "position") is read as keyed by joint name."""
    from service.api.inputs import _joint_state

    assert _joint_state({"name": [0.1], "position": [0.2]}) is None
    assert _joint_state({"name": ["j"], "position": [0.2]}) is not None
