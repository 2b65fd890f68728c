"""For MJCF models q is MuJoCo's qpos and v its qvel, exactly (quaternions w first).

Checked against MuJoCo itself on models with a ball joint, a free joint, and both with hinges:
at random (qpos, qvel, qacc) the service's M(q), C(q, v) v + g(q) and inverse dynamics equal
`mj_fullM`, `qfrc_bias` and `mj_rne` (relative 1e-10); one semi-implicit step of simulate equals
MuJoCo's own integration of the same state (`mj_integratePos`), w-first; the described
configurations are MuJoCo's `qpos0` and keyframes; the binary form, the stream, joint names, a
PD target, contacts, frame placements and reduced models take and give the same convention.
"""

from __future__ import annotations

from collections.abc import Iterator

import mujoco
import numpy as np
import orjson
import pytest
from fastapi.testclient import TestClient

from service.registry import Registry
from tests.helpers import registry_client
from tests.service.api.encoding.test_binary import BIN, decode_answer, encode_request
from tests.service.registry.mjcf_models import floating_mjcf
from tests.service.registry.mjcf_reference import relative_error

EXACT = 1e-10

BALL_MJCF = """<mujoco model="ball">
  <worldbody>
    <body name="bob" pos="0 0 1" quat="0.9 0.1 0.3 0.2">
      <joint name="socket" type="ball" armature="0.01"/>
      <inertial pos="0.05 0.02 -0.3" mass="2" fullinertia="0.05 0.06 0.02 0.003 -0.002 0.001"/>
      <site name="tip" pos="0 0 -0.4"/>
    </body>
  </worldbody>
  <keyframe><key name="tilted" qpos="0.5 0.5 0.5 0.5"/></keyframe>
</mujoco>
"""

FREE_MJCF = floating_mjcf(free_joint=True, torso_pos="0.3 -0.2 1.5")

MIXED_MJCF = """<mujoco model="mixed">
  <compiler angle="radian"/>
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint name="float"/>
      <inertial pos="0.01 0 0" mass="5" diaginertia="0.1 0.2 0.15"/>
      <body name="upper" pos="0.2 0 0">
        <joint name="hip" axis="0 1 0" ref="0.3" armature="0.02"/>
        <inertial pos="0 0 -0.2" mass="1.5" diaginertia="0.02 0.02 0.003"/>
        <body name="lower" pos="0 0 -0.4" euler="0.1 0.2 0.3">
          <joint name="ankle" type="ball"/>
          <inertial pos="0.02 0.01 -0.15" mass="0.8" diaginertia="0.01 0.012 0.002"/>
          <body name="toe" pos="0 0 -0.3">
            <joint name="toe_hinge" axis="1 0 0"/>
            <inertial pos="0.05 0 0" mass="0.2" diaginertia="0.001 0.001 0.001"/>
            <site name="toe_tip" pos="0.1 0 0"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <keyframe>
    <key name="crouch" qpos="0.1 0 0.8 0.5 0.5 0.5 0.5 0.7 0 0 1 0 -0.4"/>
  </keyframe>
</mujoco>
"""

MODELS = {"ball": BALL_MJCF, "free": FREE_MJCF, "mixed": MIXED_MJCF}


@pytest.fixture(scope="module")
def registry(tmp_path_factory: pytest.TempPathFactory) -> Registry:
    reg = Registry(tmp_path_factory.mktemp("qpos"), [])
    reg.load()
    return reg


@pytest.fixture(scope="module")
def client(registry: Registry) -> Iterator[TestClient]:
    with registry_client(registry) as c:
        yield c


@pytest.fixture(scope="module")
def uploaded(client: TestClient) -> dict[str, dict]:
    out = {}
    for name, text in MODELS.items():
        r = client.post("/v1/robots", json={"mjcf": text, "inertia_check": "warn"})
        assert r.status_code in (200, 201), r.text
        out[name] = r.json()
    return out


def post(client: TestClient, robot_id: str, quantity: str, **body) -> dict:
    r = client.post(
        f"/v1/robots/{robot_id}/{quantity}",
        json={
            k: np.asarray(v).tolist() if isinstance(v, np.ndarray) else v for k, v in body.items()
        },
    )
    assert r.status_code == 200, r.text
    return r.json()


def mujoco_states(mj: mujoco.MjModel, seed: int, count: int):
    """(qpos, qvel, qacc, M, bias, tau = M qacc + bias by mj_rne, data) at random states: qpos
    with normalised w-first quaternions away from qpos0."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        data = mujoco.MjData(mj)
        data.qpos[:] = mj.qpos0
        mujoco.mj_integratePos(mj, data.qpos, rng.normal(size=mj.nv), 1.0)
        data.qvel[:] = rng.normal(size=mj.nv)
        mujoco.mj_forward(mj, data)
        M = np.zeros((mj.nv, mj.nv))
        mujoco.mj_fullM(mj, data, M)
        qacc = rng.normal(size=mj.nv)
        data.qacc[:] = qacc
        tau = np.zeros(mj.nv)
        mujoco.mj_rne(mj, data, 1, tau)  # M a + bias without the armature's share (M's)
        tau += mj.dof_armature * qacc
        yield data.qpos.copy(), data.qvel.copy(), qacc, M, data.qfrc_bias.copy(), tau, data


def quaternion_slices(mj: mujoco.MjModel) -> list[slice]:
    out = []
    for j in range(mj.njnt):
        adr = int(mj.jnt_qposadr[j])
        if mj.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            out.append(slice(adr + 3, adr + 7))
        elif mj.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL:
            out.append(slice(adr, adr + 4))
    return out


@pytest.mark.parametrize("name", MODELS)
def test_dynamics_at_qpos_and_qvel_are_mujocos(client, uploaded, name) -> None:
    mj = mujoco.MjModel.from_xml_string(MODELS[name])
    robot_id = uploaded[name]["id"]
    assert (uploaded[name]["nq"], uploaded[name]["nv"]) == (mj.nq, mj.nv)
    for qpos, qvel, qacc, M, bias, tau, _ in mujoco_states(mj, 7, 5):
        assert all(abs(qpos[s][0]) < 0.999 for s in quaternion_slices(mj))  # not identity
        got_M = np.array(post(client, robot_id, "mass-matrix", q=qpos)["mass_matrix"])
        got_h = post(client, robot_id, "nonlinear-effects", q=qpos, v=qvel)["nonlinear_effects"]
        got_tau = post(client, robot_id, "inverse-dynamics", q=qpos, v=qvel, a=qacc)["tau"]
        assert relative_error(got_M, M) < EXACT
        assert relative_error(np.array(got_h), bias) < EXACT
        assert relative_error(np.array(got_tau), tau) < EXACT
        assert relative_error(np.array(got_tau), M @ qacc + bias) < EXACT


@pytest.mark.parametrize("name", MODELS)
def test_described_configurations_are_mujocos_qpos(client, uploaded, name) -> None:
    mj = mujoco.MjModel.from_xml_string(MODELS[name])
    info = uploaded[name]
    refs = info["reference_configurations"]
    np.testing.assert_array_equal(refs["qpos0"], mj.qpos0)
    for k in range(mj.nkey):
        np.testing.assert_allclose(refs[mj.key(k).name], mj.key_qpos[k], rtol=0, atol=1e-15)
    neutral = np.array(info["neutral_configuration"])
    for s in quaternion_slices(mj):
        np.testing.assert_array_equal(neutral[s], [1, 0, 0, 0])  # identity, w first
    assert info["default_configuration"] == info["neutral_configuration"]
    # the joint table is MuJoCo's layout: each joint's segment where qpos has it
    joints = {j["name"]: j for j in info["joints"]}
    for j in range(mj.njnt):
        name_j = mj.joint(j).name
        if mj.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            assert joints[name_j]["idx_q"] == mj.jnt_qposadr[j]
            assert joints[f"{name_j}_rotation"]["idx_q"] == mj.jnt_qposadr[j] + 3
        else:
            assert joints[name_j]["idx_q"] == mj.jnt_qposadr[j]


@pytest.mark.parametrize("name", MODELS)
def test_one_simulated_step_is_mujocos_integration(client, uploaded, name) -> None:
    """simulate's q is qpos (w first): one semi-implicit Euler step from (qpos, qvel) is
    v₁ = qvel + dt a, q₁ = qpos ⊕ dt v₁ as MuJoCo integrates it (`mj_integratePos`)."""
    mj = mujoco.MjModel.from_xml_string(MODELS[name])
    dt = 1e-3
    for qpos, qvel, _qacc, _M, _bias, _tau, data in mujoco_states(mj, 11, 3):
        out = post(client, uploaded[name]["id"], "simulate", q=qpos, v=qvel, dt=dt, steps=1)
        q, v = np.array(out["q"]), np.array(out["v"])
        np.testing.assert_array_equal(q[0], qpos)  # the initial state, as given
        v1 = qvel + dt * data.qacc_smooth  # MuJoCo's unconstrained acceleration
        q1 = qpos.copy()
        mujoco.mj_integratePos(mj, q1, v1, dt)
        assert relative_error(v[1], v1) < EXACT
        assert relative_error(q[1], q1) < EXACT
        for s in quaternion_slices(mj):
            assert abs(np.linalg.norm(q[1][s]) - 1) < 1e-12
        # a PD target of qpos itself (w first) with kd = 0 exerts nothing
        held = post(
            client,
            uploaded[name]["id"],
            "simulate",
            q=qpos,
            v=qvel,
            dt=dt,
            steps=1,
            controller={"type": "pd", "kp": 50.0, "kd": 0.0, "q_target": qpos.tolist()},
        )
        np.testing.assert_allclose(held["q"], out["q"], rtol=0, atol=1e-14)
        # ... while a target of another orientation does
        target = qpos.copy()
        mujoco.mj_integratePos(mj, target, np.full(mj.nv, 0.3), 1.0)
        pulled = post(
            client,
            uploaded[name]["id"],
            "simulate",
            q=qpos,
            v=qvel,
            dt=dt,
            steps=1,
            controller={"type": "pd", "kp": 50.0, "kd": 0.0, "q_target": target.tolist()},
        )
        assert np.abs(np.array(pulled["v"][1]) - v[1]).max() > 1e-3


def test_joint_names_and_fill_use_qpos_order(client, uploaded) -> None:
    mj = mujoco.MjModel.from_xml_string(MIXED_MJCF)
    robot_id = uploaded["mixed"]["id"]
    qpos, qvel, *_ = next(mujoco_states(mj, 3, 1))
    named = {
        "float": qpos[0:3].tolist(),
        "float_rotation": qpos[3:7].tolist(),
        "hip": qpos[7],
        "ankle": qpos[8:12].tolist(),
        "toe_hinge": qpos[12],
    }
    plain = post(client, robot_id, "mass-matrix", q=qpos)
    assert post(client, robot_id, "mass-matrix", q=named) == plain
    # missing joints from the keyframe (MuJoCo's qpos, w first)
    crouch = mj.key_qpos[0].copy()
    partial = post(client, robot_id, "mass-matrix", q={"hip": qpos[7]}, fill="crouch")
    crouch[7] = qpos[7]
    assert partial == post(client, robot_id, "mass-matrix", q=crouch)
    neutral = np.array(uploaded["mixed"]["neutral_configuration"])
    neutral[7] = qpos[7]
    assert post(client, robot_id, "mass-matrix", q={"hip": qpos[7]}, fill="neutral") == post(
        client, robot_id, "mass-matrix", q=neutral
    )
    # answers keyed by name: the rotation w first
    out = post(client, robot_id, "simulate", q=named, v=qvel, dt=1e-3, steps=1, joint_names=True)
    assert out["q"][0]["float_rotation"] == qpos[3:7].tolist()
    assert out["q"][0]["ankle"] == qpos[8:12].tolist()


def test_binary_and_stream_give_what_json_gives(client, uploaded) -> None:
    mj = mujoco.MjModel.from_xml_string(MIXED_MJCF)
    robot_id = uploaded["mixed"]["id"]
    states = list(mujoco_states(mj, 5, 4))
    q, v, a = (np.stack([s[i] for s in states]) for i in range(3))
    expected = post(client, robot_id, "inverse-dynamics", q=q, v=v, a=a)
    for i, s in enumerate(states):
        assert relative_error(np.array(expected["tau"][i]), s[5]) < EXACT
    r = client.post(
        f"/v1/robots/{robot_id}/inverse-dynamics",
        content=encode_request({"q": q, "v": v, "a": a}),
        headers={"Content-Type": BIN, "Accept": BIN},
    )
    assert r.status_code == 200, r.text
    np.testing.assert_array_equal(decode_answer(r.content)["tau"], expected["tau"])
    sim = post(client, robot_id, "simulate", q=q, v=v, dt=1e-3, steps=2)
    r = client.post(
        f"/v1/robots/{robot_id}/simulate",
        content=encode_request({"q": q, "v": v}, {"dt": 1e-3, "steps": 2}),
        headers={"Content-Type": BIN, "Accept": BIN},
    )
    assert r.status_code == 200, r.text
    np.testing.assert_array_equal(decode_answer(r.content)["q"], sim["q"])
    with client.websocket_connect(f"/v1/robots/{robot_id}/stream") as ws:
        ws.send_text(
            orjson.dumps(
                {
                    "quantity": "inverse-dynamics",
                    "q": q[0].tolist(),
                    "v": v[0].tolist(),
                    "a": a[0].tolist(),
                }
            ).decode()
        )
        assert ws.receive_json()["tau"] == expected["tau"][0]
        ws.send_bytes(encode_request({"q": q, "v": v, "a": a}, {"quantity": "inverse-dynamics"}))
        np.testing.assert_array_equal(decode_answer(ws.receive_bytes())["tau"], expected["tau"])


def test_frame_placements_at_qpos_are_mujocos(client, uploaded) -> None:
    mj = mujoco.MjModel.from_xml_string(MIXED_MJCF)
    for qpos, *_, data in mujoco_states(mj, 9, 3):
        out = post(
            client, uploaded["mixed"]["id"], "frame-placements", q=qpos, frames=["toe_tip", "lower"]
        )
        np.testing.assert_allclose(out["positions"][0], data.site_xpos[0], atol=1e-12)
        np.testing.assert_allclose(out["positions"][1], data.xpos[mj.body("lower").id], atol=1e-12)


def test_contacts_take_and_give_qpos(client, uploaded) -> None:
    """A 6-D contact at the floating base holds it: simulate with it answers w-first q that
    stays at the initial qpos, and contact inverse dynamics takes qpos."""
    mj = mujoco.MjModel.from_xml_string(MIXED_MJCF)
    robot_id = uploaded["mixed"]["id"]
    qpos, _qvel, qacc, *_ = next(mujoco_states(mj, 4, 1))
    contacts = [{"frame": "base", "type": "6d"}]
    zero = np.zeros(mj.nv)
    out = post(client, robot_id, "simulate", q=qpos, v=zero, dt=1e-3, steps=5, contacts=contacts)
    q = np.array(out["q"])
    np.testing.assert_array_equal(q[0], qpos)
    np.testing.assert_allclose(q[-1][:7], qpos[:7], atol=1e-9)  # the base is held, w first
    a = qacc.copy()
    a[:6] = 0  # the held base does not accelerate
    r = post(client, robot_id, "contact-inverse-dynamics", q=qpos, v=zero, a=a, contacts=contacts)
    tau = post(client, robot_id, "inverse-dynamics", q=qpos, v=zero, a=a)["tau"]
    np.testing.assert_allclose(r["tau"][6:], tau[6:], atol=1e-9)


def test_unit_norm_is_checked_and_named_w_first(client, uploaded) -> None:
    q = np.array(uploaded["ball"]["neutral_configuration"])
    q[0] = 1.1
    r = client.post(f"/v1/robots/{uploaded['ball']['id']}/gravity", json={"q": q.tolist()})
    assert r.status_code == 422 and r.json()["code"] == "invalid_configuration"
    assert "quaternion (w, x, y, z)" in r.json()["detail"]


def test_reduced_and_reloaded_models_keep_qpos(client, uploaded, registry) -> None:
    mj = mujoco.MjModel.from_xml_string(MIXED_MJCF)
    robot_id = uploaded["mixed"]["id"]
    qpos, *_ = next(mujoco_states(mj, 8, 1))
    full = np.array(post(client, robot_id, "mass-matrix", q=qpos)["mass_matrix"])
    # locking the hinge keeps the free and ball joints: still w first
    r = client.post(f"/v1/robots/{robot_id}/reduce", json={"locked_joints": {"hip": qpos[7]}})
    assert r.status_code in (200, 201), r.text
    reduced = r.json()
    keep = [*range(7), *range(8, 13)]
    got = np.array(post(client, reduced["id"], "mass-matrix", q=qpos[keep])["mass_matrix"])
    vkeep = [*range(6), *range(7, 11)]
    assert relative_error(got, full[np.ix_(vkeep, vkeep)]) < EXACT
    np.testing.assert_allclose(
        reduced["reference_configurations"]["qpos0"], mj.qpos0[keep], atol=1e-15
    )
    # locking the ball joint takes its quaternion w first, as in qpos
    r = client.post(
        f"/v1/robots/{robot_id}/reduce", json={"locked_joints": {"ankle": qpos[8:12].tolist()}}
    )
    assert r.status_code in (200, 201), r.text
    keep = [*range(8), 12]
    got = np.array(post(client, r.json()["id"], "mass-matrix", q=qpos[keep])["mass_matrix"])
    vkeep = [*range(7), 10]
    assert relative_error(got, full[np.ix_(vkeep, vkeep)]) < EXACT
    # a registry reloading the store serves the same convention
    again = Registry(registry.store.dir.parent, [])
    again.load()
    for served in (robot_id, reduced["id"]):
        robot = again.get(served)
        assert robot.mujoco_qpos and robot.q_from_api is not None
        assert robot.info() == registry.get(served).info()
