"""Contacts on uploaded robots: a frame name shared by a joint and a link means the link's body
frame in `simulate` as on every route, and an MJCF free joint is a floating root exactly like
the free-flyer of the same robot uploaded as URDF (same contact forces carrying m g, zero
torque on the base, the same contact-consistent gravity compensation in `simulate`)."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient

from service.registry import Registry
from tests.helpers import registry_client

G = 9.81

_INERTIAL = (
    '<inertial><origin xyz="{x} 0 {z}"/><mass value="{m}"/><inertia ixx="{i}" '
    'ixy="0" ixz="0" iyy="{i}" iyz="0" izz="{i}"/></inertial>'
)
_LIMIT = '<limit lower="-3" upper="3" effort="50" velocity="5"/>'

# A 3-link arm whose second joint is named like the third link ("link3"): the model has a
# JOINT frame and a BODY frame of that name (model.getFrameId("link3") refuses to choose).
SAME_NAME_ARM = f"""<robot name="same_name_arm">
  <link name="link1">{_INERTIAL.format(x=0.2, z=0, m=1.0, i=0.01)}</link>
  <link name="link2">{_INERTIAL.format(x=0.2, z=0, m=1.0, i=0.01)}</link>
  <link name="link3">{_INERTIAL.format(x=0.2, z=0, m=1.0, i=0.01)}</link>
  <joint name="j1" type="revolute"><parent link="link1"/><child link="link2"/>
    <origin xyz="0.4 0 0"/><axis xyz="0 1 0"/>{_LIMIT}</joint>
  <joint name="link3" type="revolute"><parent link="link2"/><child link="link3"/>
    <origin xyz="0.4 0 0"/><axis xyz="0 1 0"/>{_LIMIT}</joint>
</robot>
"""

# An 11 kg one-legged hopper: a torso on an MJCF free joint, hip, knee and ankle hinges, a
# flat sole (a site); and its URDF twin (free-flyer root, the sole a fixed frame).
HOPPER_MJCF = """<mujoco model="hopper">
  <compiler angle="radian"/>
  <worldbody>
    <body name="torso" pos="0 0 1.0">
      <freejoint name="root"/>
      <inertial pos="0 0 0.05" mass="5" diaginertia="0.1 0.1 0.05"/>
      <body name="thigh" pos="0 0 -0.05">
        <joint name="hip" axis="0 1 0" range="-3 3"/>
        <inertial pos="0 0 -0.2" mass="3" diaginertia="0.04 0.04 0.005"/>
        <body name="shin" pos="0 0 -0.4">
          <joint name="knee" axis="0 1 0" range="-3 3"/>
          <inertial pos="0 0 -0.2" mass="2" diaginertia="0.03 0.03 0.004"/>
          <body name="foot" pos="0 0 -0.4">
            <joint name="ankle" axis="0 1 0" range="-3 3"/>
            <inertial pos="0.05 0 -0.05" mass="1" diaginertia="0.002 0.004 0.004"/>
            <site name="sole" pos="0.05 0 -0.1"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _link(name: str, x: float, z: float, m: float, ixx: float, iyy: float, izz: float) -> str:
    return (
        f'<link name="{name}"><inertial><origin xyz="{x} 0 {z}"/><mass value="{m}"/>'
        f'<inertia ixx="{ixx}" ixy="0" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/>'
        "</inertial></link>"
    )


def _hinge(name: str, parent: str, child: str, z: float) -> str:
    return (
        f'<joint name="{name}" type="revolute"><parent link="{parent}"/>'
        f'<child link="{child}"/><origin xyz="0 0 {z}"/><axis xyz="0 1 0"/>{_LIMIT}'
        "</joint>"
    )


HOPPER_URDF = f"""<robot name="hopper">
  {_link("torso", 0, 0.05, 5, 0.1, 0.1, 0.05)}
  {_link("thigh", 0, -0.2, 3, 0.04, 0.04, 0.005)}
  {_link("shin", 0, -0.2, 2, 0.03, 0.03, 0.004)}
  {_link("foot", 0.05, -0.05, 1, 0.002, 0.004, 0.004)}
  <link name="sole"/>
  {_hinge("hip", "torso", "thigh", -0.05)}
  {_hinge("knee", "thigh", "shin", -0.4)}
  {_hinge("ankle", "shin", "foot", -0.4)}
  <joint name="sole_joint" type="fixed"><parent link="foot"/><child link="sole"/>
    <origin xyz="0.05 0 -0.1"/></joint>
</robot>
"""

SOLE = [{"frame": "sole", "type": "6d"}]
BENT = [0.3, -0.6, 0.3]  # hip, knee, ankle: the sole stays flat


@pytest.fixture(scope="module")
def registry(tmp_path_factory: pytest.TempPathFactory) -> Registry:
    reg = Registry(tmp_path_factory.mktemp("contact_uploads"), [])
    reg.load()
    return reg


@pytest.fixture(scope="module")
def client(registry: Registry) -> Iterator[TestClient]:
    with registry_client(registry) as c:
        yield c


def _upload(client: TestClient, **body) -> str:
    r = client.post("/v1/robots", json={**body, "inertia_check": "warn"})
    assert r.status_code in (200, 201), r.text
    return r.json()["id"]


def _post(client: TestClient, robot_id: str, quantity: str, **body) -> dict[str, np.ndarray]:
    r = client.post(
        f"/v1/robots/{robot_id}/{quantity}",
        json={
            k: np.asarray(v).tolist() if isinstance(v, np.ndarray) else v for k, v in body.items()
        },
    )
    assert r.status_code == 200, r.text
    return {k: np.asarray(v) for k, v in r.json().items()}


def test_simulate_resolves_a_shared_name_to_the_links_body_frame(client, registry):
    """A point contact on "link3" (a joint and a link of that name) in simulate answers 200
    (Pinocchio's lookup by name alone raises "Several frames match the filter"), and the body
    frame's origin stays put
    while the floating arm swings about it under gravity."""
    robot_id = _upload(client, urdf=SAME_NAME_ARM, root_joint="free-flyer")
    model = registry.get(robot_id).model
    data = model.createData()
    body = model.getFrameId("link3", pin.FrameType.BODY)
    root = model.getFrameId("link1", pin.FrameType.BODY)
    q0 = pin.neutral(model)
    q0[7:] = [0.4, -0.8]
    out = _post(
        client,
        robot_id,
        "simulate",
        q=q0,
        v=np.zeros(model.nv),
        dt=1e-3,
        steps=300,
        integrator="rk4",
        contacts=[{"frame": "link3", "type": "point"}],
    )
    pin.framesForwardKinematics(model, data, q0)
    anchor, root_start = data.oMf[body].translation.copy(), data.oMf[root].translation.copy()
    held, swung = [], []
    for q in out["q"]:
        pin.framesForwardKinematics(model, data, q)
        held.append(np.linalg.norm(data.oMf[body].translation - anchor))
        swung.append(np.linalg.norm(data.oMf[root].translation - root_start))
    assert max(held) < 1e-6
    np.testing.assert_allclose(out["constraint_drift"], held, atol=1e-12)
    assert max(swung) > 1e-2  # it hangs from that point and swings under gravity
    # contact-dynamics on the same name: the constrained acceleration of the body frame is 0
    a = _post(
        client,
        robot_id,
        "contact-dynamics",
        q=q0,
        v=np.zeros(model.nv),
        tau=np.zeros(model.nv),
        contacts=[{"frame": "link3"}],
    )["a"]
    pin.forwardKinematics(model, data, q0, np.zeros(model.nv), a)
    pin.updateFramePlacements(model, data)
    acc = pin.getFrameClassicalAcceleration(
        model, data, body, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    ).linear
    assert np.abs(acc).max() < 1e-9


@pytest.fixture(scope="module")
def hoppers(client) -> dict[str, str]:
    return {
        "mjcf": _upload(client, mjcf=HOPPER_MJCF),
        "urdf": _upload(client, urdf=HOPPER_URDF, root_joint="free-flyer"),
    }


def _q(kind: str, position=(0.0, 0.0, 1.0), joints=BENT) -> np.ndarray:
    """The standing configuration in each robot's q: MJCF qpos has the quaternion w first,
    the URDF free-flyer's q has it last."""
    quat = [1.0, 0, 0, 0] if kind == "mjcf" else [0, 0, 0, 1.0]
    return np.array([*position, *quat, *joints])


def test_an_mjcf_free_joint_is_a_floating_root_like_the_urdf_twins_free_flyer(
    client, hoppers, registry
):
    """Standing still on its sole: zero torque on the six base rows, contact forces carrying
    m g (11 kg) with no residual, and the same τ and forces for both twins (1e-9)."""
    answers = {}
    for kind, robot_id in hoppers.items():
        robot = registry.get(robot_id)
        assert robot.total_mass == pytest.approx(11.0) and robot.nv == 9
        zero = np.zeros(robot.nv)
        out = _post(
            client, robot_id, "contact-inverse-dynamics", q=_q(kind), v=zero, a=zero, contacts=SOLE
        )
        np.testing.assert_array_equal(out["tau"][:6], 0.0)
        assert out["residual"] <= 1e-9 * 11 * G
        assert out["contact_forces"][2] == pytest.approx(11 * G, rel=1e-12)
        assert np.abs(out["contact_forces"][:2]).max() <= 1e-9
        answers[kind] = out
    np.testing.assert_allclose(answers["mjcf"]["tau"], answers["urdf"]["tau"], atol=1e-9)
    np.testing.assert_allclose(
        answers["mjcf"]["contact_forces"], answers["urdf"]["contact_forces"], atol=1e-9
    )
    # and that τ holds the MJCF robot still under its contact
    zero = np.zeros(9)
    held = _post(
        client,
        hoppers["mjcf"],
        "contact-dynamics",
        q=_q("mjcf"),
        v=zero,
        tau=answers["mjcf"]["tau"],
        contacts=SOLE,
    )
    assert np.abs(held["a"]).max() <= 1e-9


def test_simulated_pd_on_an_mjcf_free_joint_acts_on_the_joints_only(client, hoppers):
    """simulate with the sole held, contact-consistent gravity compensation and zero gains:
    the posture is an equilibrium for both twins (a base torque would push it away), and
    under PD gains from a perturbed posture both twins move alike."""
    for kind, robot_id in hoppers.items():
        q0 = _q(kind)
        out = _post(
            client,
            robot_id,
            "simulate",
            q=q0,
            v=np.zeros(9),
            dt=1e-3,
            steps=100,
            contacts=SOLE,
            integrator="rk4",
            controller={
                "type": "pd",
                "kp": 0.0,
                "kd": 0.0,
                "q_target": q0.tolist(),
                "gravity_compensation": True,
            },
        )
        assert np.abs(out["v"]).max() < 1e-8, kind
    moved = {}
    for kind, robot_id in hoppers.items():
        target = _q(kind)
        start = _q(kind, joints=[0.35, -0.65, 0.3])
        out = _post(
            client,
            robot_id,
            "simulate",
            q=start,
            v=np.zeros(9),
            dt=1e-3,
            steps=200,
            contacts=SOLE,
            integrator="rk4",
            controller={
                "type": "pd",
                "kp": 50.0,
                "kd": 2.0,
                "q_target": target.tolist(),
                "gravity_compensation": True,
            },
        )
        moved[kind] = out
    # base position and joint angles agree (the quaternions only differ in their order)
    np.testing.assert_allclose(moved["mjcf"]["q"][:, :3], moved["urdf"]["q"][:, :3], atol=1e-9)
    np.testing.assert_allclose(moved["mjcf"]["q"][:, 7:], moved["urdf"]["q"][:, 7:], atol=1e-9)
    assert np.abs(moved["mjcf"]["q"][-1, 7:] - moved["mjcf"]["q"][0, 7:]).max() > 1e-3
