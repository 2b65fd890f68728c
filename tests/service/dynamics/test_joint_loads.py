"""Joint loads: the wrench each joint transmits (inverse dynamics with `"loads": true`) against
Pinocchio's `data.f` after RNEA (with payloads composed by hand, external forces and friction),
and against statics by hand: a horizontal two-link arm, and a vertical-axis joint holding a
horizontal link (its bearing carries the bending moment m g × lever, its motor nothing)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.dynamics.equation_of_motion import inverse_dynamics
from service.dynamics.joint_loads import bearing_loads, joint_axes
from service.registry.robot import Robot
from service.states import prepare
from tests.helpers import random_state

G = 9.81

# A link of 2 kg whose centre of mass is 0.5 m from a vertical (z) axis: the joint holds it
# horizontal, turning about the vertical.
TURNTABLE = """<robot name="turntable"><link name="base"/>
<link name="arm"><inertial><origin xyz="0.5 0 0"/><mass value="2"/>
<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
<joint name="turn" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
<limit lower="-3" upper="3" effort="10" velocity="5"/></joint></robot>"""


def _robot(urdf: str, name: str) -> Robot:
    model = pin.buildModelFromXML(urdf)
    return Robot(id=name, name=name, source="upload", root_joint="fixed", model=model)


def _data_f(model, q, v, a, fext=None) -> np.ndarray:
    """Pinocchio's data.f of the moving joints after RNEA, (joints, 6)."""
    data = model.createData()
    if fext is None:
        pin.rnea(model, data, q, v, a)
    else:
        pin.rnea(model, data, q, v, a, fext)
    return np.array([data.f[j].vector for j in range(1, model.njoints)])


def test_horizontal_two_link_arm_by_hand(small_app_factory):
    client = small_app_factory(catalog="planar_arm")
    body = {"q": [0.0, 0.0], "v": [0.0, 0.0], "a": [0.0, 0.0], "loads": True}
    answer = client.post("/v1/robots/planar_arm/inverse-dynamics", json=body).json()
    shoulder, elbow = np.array(answer["joint_wrenches"])
    m1, m2, l1, l2 = 2.0, 1.5, 1.0, 0.7
    # The joint frames are the world's at q = 0: each joint carries the weight of what is
    # outboard of it (+z) and its moment about the joint, r × F, along y (the axes are −y).
    np.testing.assert_allclose(
        shoulder, [0, 0, (m1 + m2) * G, 0, -G * (m1 * l1 + m2 * (l1 + l2)), 0], atol=1e-12
    )
    np.testing.assert_allclose(elbow, [0, 0, m2 * G, 0, -G * m2 * l2, 0], atol=1e-12)
    # τ = s · n with s = (0, −1, 0): the torques of the answer; the bearings carry no bending
    np.testing.assert_allclose(answer["tau"], [-shoulder[4], -elbow[4]], atol=1e-12)
    loads = bearing_loads(np.array([[shoulder, elbow]]), joint_axes(_robot_of(client)).axes)
    np.testing.assert_allclose(loads["bending_moment"], 0.0, atol=1e-12)
    np.testing.assert_allclose(loads["force"][0], [(m1 + m2) * G, m2 * G])


def _robot_of(client) -> Robot:
    return client.app.state.registry.catalog["planar_arm"]


@pytest.mark.parametrize("angle", [0.0, 0.7, -2.0])
def test_vertical_axis_joint_holding_a_horizontal_link(angle):
    robot = _robot(TURNTABLE, "turntable")
    states = prepare(robot, {"q": [angle], "v": [0.0], "a": [0.0]}, max_batch=1)
    result = inverse_dynamics(robot, states, loads=True)
    wrench = result["joint_wrenches"][0]
    loads = {
        k: float(x[0, 0]) for k, x in bearing_loads(wrench[None], joint_axes(robot).axes).items()
    }
    m, lever = 2.0, 0.5
    assert result["tau"][0, 0] == pytest.approx(0.0, abs=1e-12)  # the motor holds nothing
    assert loads["bending_moment"] == pytest.approx(m * G * lever, rel=1e-12)
    assert loads["axial_force"] == pytest.approx(m * G, rel=1e-12)  # the bearing's thrust
    assert loads["moment"] == pytest.approx(m * G * lever, rel=1e-12)
    # in the joint's axes (turning with the link): weight along +z, moment about −y
    np.testing.assert_allclose(wrench[0], [0, 0, m * G, 0, -m * G * lever, 0], atol=1e-12)


@pytest.mark.parametrize("name", ["ur5", "talos"])
def test_wrenches_are_pinocchios_data_f(catalog_registry, name):
    robot = catalog_registry.catalog[name]
    rng = np.random.default_rng(3)
    states = [random_state(robot.model, rng) for _ in range(3)]
    q, v, a = (np.array(x) for x in zip(*states, strict=True))
    prepared = prepare(robot, {"q": q, "v": v, "a": a}, max_batch=10)
    result = inverse_dynamics(robot, prepared, loads=True)
    assert result["joint_wrenches"].shape == (3, robot.model.njoints - 1, 6)
    for i in range(3):
        np.testing.assert_allclose(
            result["joint_wrenches"][i], _data_f(robot.model, q[i], v[i], a[i]), atol=1e-9
        )
    np.testing.assert_array_equal(result["tau"], inverse_dynamics(robot, prepared)["tau"])


def test_wrenches_with_a_payload_external_force_and_friction_over_http(small_app_factory):
    client = small_app_factory(catalog="ur5")
    robot = client.app.state.registry.catalog["ur5"]
    rng = np.random.default_rng(8)
    q, v, a = random_state(robot.model, rng)
    payload = {"frame": "tool0", "mass": 3.0, "center_of_mass": [0.0, 0.01, 0.05]}
    push = {
        "frame": "wrist_1_link",
        "wrench": [5.0, -2.0, 1.0, 0.3, 0.0, -0.2],
        "reference_frame": "local",
    }
    body = {
        "q": q.tolist(),
        "v": v.tolist(),
        "a": a.tolist(),
        "loads": True,
        "payloads": [payload],
        "external_forces": [push],
    }
    answer = client.post("/v1/robots/ur5/inverse-dynamics", json=body)
    assert answer.status_code == 200, answer.text
    # by hand: the payload composed into a model copy, the wrench in its frame's parent joint
    carried = pin.Model(robot.model)
    tool = carried.frames[carried.getFrameId("tool0")]
    carried.inertias[tool.parentJoint] += tool.placement.act(
        pin.Inertia(3.0, np.array([0.0, 0.01, 0.05]), np.zeros((3, 3)))
    )
    frame = carried.frames[carried.getFrameId("wrist_1_link")]
    fext = pin.StdVec_Force()
    fext.extend(pin.Force.Zero() for _ in range(carried.njoints))
    fext[frame.parentJoint] = frame.placement.act(pin.Force(np.array(push["wrench"])))
    expected = _data_f(carried, q, v, a, fext)
    np.testing.assert_allclose(answer.json()["joint_wrenches"], expected, atol=1e-9)
    # one state: [joints][6]; a batch gains the N axis; without `loads` no wrenches
    batch = client.post(
        "/v1/robots/ur5/inverse-dynamics",
        json={"q": [q.tolist()] * 2, "v": [v.tolist()] * 2, "a": [a.tolist()] * 2, "loads": True},
    ).json()
    assert np.shape(batch["joint_wrenches"]) == (2, 6, 6)
    plain = client.post(
        "/v1/robots/ur5/inverse-dynamics", json={"q": q.tolist(), "v": v.tolist(), "a": a.tolist()}
    )
    assert "joint_wrenches" not in plain.json()


def test_friction_adds_along_the_axis_only(catalog_registry):
    base = catalog_registry.catalog["ur5"]
    friction = {
        "coulomb": np.linspace(0.5, 1.0, 6),
        "viscous": np.full(6, 0.3),
        "offset": np.linspace(-0.1, 0.1, 6),
    }
    rough = Robot(
        id="ur5_rough",
        name="ur5_rough",
        source="upload",
        root_joint="fixed",
        model=base.model,
        friction=friction,
    )
    rng = np.random.default_rng(5)
    q, v, a = random_state(base.model, rng)
    states = prepare(base, {"q": q, "v": v, "a": a}, max_batch=1)
    plain = inverse_dynamics(base, states, loads=True)["joint_wrenches"][0]
    rough_loads = inverse_dynamics(rough, states, loads=True, friction=True)
    torque = friction["offset"] + friction["coulomb"] * np.sign(v) + friction["viscous"] * v
    axes = joint_axes(base).axes  # UR5: every joint revolute, s is the moment's direction
    change = rough_loads["joint_wrenches"][0] - plain
    np.testing.assert_allclose(change[:, :3], 0.0, atol=1e-12)  # no force
    np.testing.assert_allclose(change[:, 3:], torque[:, None] * axes, atol=1e-12)
    # τ = s · n, friction included (UR5 has no armature)
    np.testing.assert_allclose(
        np.einsum("jk,jk->j", rough_loads["joint_wrenches"][0][:, 3:], axes),
        rough_loads["tau"][0],
        atol=1e-9,
    )


def test_loads_must_be_a_boolean(small_app_factory):
    client = small_app_factory(catalog="planar_arm")
    answer = client.post(
        "/v1/robots/planar_arm/inverse-dynamics",
        json={"q": [0, 0], "v": [0, 0], "a": [0, 0], "loads": "yes"},
    )
    assert answer.status_code == 422
    assert answer.headers["content-type"].startswith("application/problem+json")
    assert "loads" in answer.json()["detail"]


def test_the_binary_form_carries_the_wrenches(small_app_factory):
    from tests.service.api.encoding.test_binary import BIN, decode_answer, encode_request

    client = small_app_factory(catalog="ur5")
    robot = client.app.state.registry.catalog["ur5"]
    rng = np.random.default_rng(4)
    q, v, a = (
        np.array(x) for x in zip(*(random_state(robot.model, rng) for _ in range(3)), strict=True)
    )
    body = encode_request({"q": q, "v": v, "a": a}, {"loads": True})
    answer = client.post(
        "/v1/robots/ur5/inverse-dynamics",
        content=body,
        headers={"content-type": BIN, "accept": BIN},
    )
    assert answer.status_code == 200, answer.text
    got = decode_answer(answer.content)
    assert got["joint_wrenches"].shape == (3, 6, 6)
    for i in range(3):
        np.testing.assert_allclose(
            got["joint_wrenches"][i], _data_f(robot.model, q[i], v[i], a[i]), atol=1e-9
        )
