"""Robots with one degree of freedom, shared frame names, and numerical inputs that stress
the binding and the solvers (answers shaped by the binding, failed solves, ragged or oversized
inputs): every
answer is shaped from nv and the task, whatever the Pinocchio binding hands back, and failures
of linear algebra or of shapes are 422s."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import orjson
import pinocchio as pin
import pytest

from service.api.encoding import binary

BIN = binary.BINARY_MEDIA_TYPE

# A pendulum: a revolute joint about y at the world origin, a point-like body of mass 1 kg with
# Iyy = 0.1 kg·m² about its centre of mass, 1 m below the joint. Link and joint are both "arm".
PENDULUM = """<robot name="pendulum"><link name="base"/>
<link name="arm"><inertial><origin xyz="0 0 -1"/><mass value="1"/>
<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
<joint name="arm" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 1 0"/>
<limit lower="-3" upper="3" effort="10" velocity="5"/></joint></robot>"""

# A link "arm" that is the PARENT of a joint also called "arm", 1 m further along x: the body
# frame (first in model order) and the joint frame of that name are in different places.
SHARED_NAMES = """<robot name="shared"><link name="base"/>
<link name="arm"><inertial><origin xyz="0.5 0 0"/><mass value="1"/>
<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
<link name="tip"><inertial><mass value="1"/>
<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
<joint name="j1" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
<limit lower="-3" upper="3" effort="10" velocity="5"/></joint>
<joint name="arm" type="revolute"><parent link="arm"/><child link="tip"/>
<origin xyz="1 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="5"/>
</joint></robot>"""


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """(client, pendulum id, 1-dof reduced UR5 id, shared-names id)."""
    from fastapi.testclient import TestClient

    from service.main import create_app
    from service.registry import Registry
    from service.settings import Settings

    settings = Settings(data_dir=tmp_path_factory.mktemp("small"), catalog="ur5")
    registry = Registry(settings.data_dir, settings.catalog_names())
    registry.load()
    with TestClient(
        create_app(settings, registry=registry), raise_server_exceptions=False
    ) as client:
        pendulum = client.post("/v1/robots", json={"urdf": PENDULUM})
        shared = client.post("/v1/robots", json={"urdf": SHARED_NAMES})
        joints = client.get("/v1/robots/ur5").json()["joints"]
        locked = {j["name"]: [0.3] for j in joints[1:]}
        reduced = client.post("/v1/robots/ur5/reduce", json={"locked_joints": locked})
        assert pendulum.status_code == shared.status_code == reduced.status_code == 201
        assert reduced.json()["nv"] == 1
        yield client, pendulum.json()["id"], reduced.json()["id"], shared.json()["id"], registry


def test_pendulum_center_of_mass_and_its_jacobian_are_the_closed_form(small):
    client, pid, *_ = small
    theta = 0.7
    r = client.post(f"/v1/robots/{pid}/center-of-mass", json={"q": [theta], "v": [2.0]})
    assert r.status_code == 200, r.text
    body = r.json()
    # c = R_y(θ) (0, 0, -1) = (-sin θ, 0, -cos θ); J_c = dc/dθ; ċ = J_c θ̇
    c = np.array([-np.sin(theta), 0.0, -np.cos(theta)])
    Jc = np.array([[-np.cos(theta)], [0.0], [np.sin(theta)]])
    np.testing.assert_allclose(body["position"], c, atol=1e-12)
    assert np.shape(body["jacobian"]) == (3, 1)
    np.testing.assert_allclose(body["jacobian"], Jc, atol=1e-12)
    np.testing.assert_allclose(body["velocity"], 2.0 * Jc[:, 0], atol=1e-12)


def test_pendulum_centroidal_momentum_matrix_is_the_closed_form(small):
    client, pid, *_ = small
    theta = -0.4
    body = client.post(
        f"/v1/robots/{pid}/centroidal", json={"q": [[theta], [theta]], "v": [[1.0], [3.0]]}
    ).json()
    # linear rows m J_c; angular rows about the centre of mass: the body's own Iyy = 0.1
    A = np.array([[-np.cos(theta)], [0.0], [np.sin(theta)], [0.0], [0.1], [0.0]])
    assert np.shape(body["momentum_matrix"]) == (2, 6, 1)
    np.testing.assert_allclose(body["momentum_matrix"][0], A, atol=1e-12)
    np.testing.assert_allclose(body["momentum"][1], 3.0 * A[:, 0], atol=1e-12)


@pytest.mark.parametrize("frame", ["arm"])
def test_pendulum_jacobian_and_damped_operational_space(small, frame):
    client, pid, *_ = small
    J = client.post(
        f"/v1/robots/{pid}/jacobian", json={"q": [0.2], "v": [1.0], "frame": frame}
    ).json()
    assert np.shape(J["jacobian"]) == (6, 1) and np.shape(J["jacobian_time_variation"]) == (6, 1)
    np.testing.assert_allclose(J["jacobian"], [[0], [0], [0], [0], [1], [0]], atol=1e-12)
    # Full task of a 1-dof robot: J M⁻¹ Jᵀ has rank 1 → singular without damping.
    r = client.post(f"/v1/robots/{pid}/operational-space", json={"q": [0.2], "frame": frame})
    assert r.status_code == 422 and r.json()["code"] == "singular_configuration"
    lam = 0.5
    r = client.post(
        f"/v1/robots/{pid}/operational-space",
        json={"q": [0.2], "v": [1.0], "frame": frame, "damping": lam},
    )
    assert r.status_code == 200, r.text
    out = r.json()
    M = 0.1 + 1.0 * 1.0**2  # Iyy about the joint: I_c + m d²
    Jm = np.array(J["jacobian"])
    Lambda = np.linalg.inv(Jm @ Jm.T / M + lam**2 * np.eye(6))
    np.testing.assert_allclose(out["inertia"], Lambda, atol=1e-12)
    assert np.shape(out["dynamically_consistent_inverse"]) == (1, 6)
    r = client.post(
        f"/v1/robots/{pid}/operational-space",
        json={"q": [0.2], "frame": frame, "task": "angular", "damping": 0.0},
    )
    assert r.status_code == 422  # angular task of one joint: still rank 1 of 3


QUANTITIES = [
    "mass-matrix",
    "gravity",
    "coriolis",
    "nonlinear-effects",
    "inverse-dynamics",
    "forward-dynamics",
    "mass-matrix-inverse",
    "energy",
    "center-of-mass",
    "jacobian",
    "operational-space",
    "inverse-dynamics-derivatives",
    "forward-dynamics-derivatives",
    "centroidal",
    "simulate",
]


@pytest.mark.parametrize("quantity", QUANTITIES)
def test_one_dof_reduced_catalog_robot_answers_every_quantity_like_pinocchio(small, quantity):
    client, _, rid, _, registry = small
    model = registry.get(rid).model
    q, v = np.array([0.4]), np.array([-1.2])
    body = {
        "q": q.tolist(),
        "v": v.tolist(),
        "a": [0.5],
        "tau": [2.0],
        "frame": "tool0",
        "damping": 0.1,
        "dt": 0.01,
        "steps": 3,
    }
    from service.api.quantities import SPECS

    body = {k: x for k, x in body.items() if k in SPECS[quantity].request.model_fields}
    r = client.post(f"/v1/robots/{rid}/{quantity}", json=body)
    assert r.status_code == 200, r.text
    data = model.createData()
    fid = model.getFrameId("tool0")
    expected = {
        "mass-matrix": ("mass_matrix", np.reshape(pin.crba(model, data, q), (1, 1))),
        "jacobian": (
            "jacobian",
            np.reshape(
                pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED), (6, 1)
            ),
        ),
        "center-of-mass": (
            "jacobian",
            np.reshape(pin.jacobianCenterOfMass(model, data, q), (3, 1)),
        ),
        "centroidal": ("momentum_matrix", np.reshape(pin.ccrba(model, data, q, v), (6, 1))),
        "forward-dynamics": ("a", pin.aba(model, data, q, v, np.array([2.0]))),
    }.get(quantity)
    if expected is not None:
        np.testing.assert_allclose(r.json()[expected[0]], expected[1], rtol=1e-9, atol=1e-12)


def test_a_name_shared_by_a_link_and_a_joint_means_the_first_frame_listed(small):
    client, *_, sid, registry = small
    frames = client.get(f"/v1/robots/{sid}").json()["frames"]
    first = next(i for i, f in enumerate(frames) if f["name"] == "arm")
    assert frames[first]["type"] == "body"  # the link comes first here, the joint after it
    model = registry.get(sid).model
    q = np.array([0.3, -0.8])
    expected = pin.computeFrameJacobian(
        model, model.createData(), q, first, pin.LOCAL_WORLD_ALIGNED
    )
    r = client.post(f"/v1/robots/{sid}/jacobian", json={"q": q.tolist(), "frame": "arm"})
    assert r.status_code == 200, r.text
    np.testing.assert_allclose(r.json()["jacobian"], expected, atol=1e-12)
    # the body frame of "arm" sits on joint j1's axis: its linear velocity is zero
    np.testing.assert_allclose(np.array(r.json()["jacobian"])[:3], 0.0, atol=1e-12)
    for quantity, extra in [
        ("operational-space", {"damping": 0.1}),
        (
            "inverse-dynamics",
            {
                "v": [0, 0],
                "a": [0, 0],
                "external_forces": [{"frame": "arm", "wrench": [1, 0, 0, 0, 0, 0]}],
            },
        ),
    ]:
        r = client.post(
            f"/v1/robots/{sid}/{quantity}",
            json={"q": q.tolist(), "frame": "arm", **extra}
            if "damping" in extra
            else {"q": q.tolist(), **extra},
        )
        assert r.status_code == 200, r.text


@pytest.mark.parametrize("damping", [1e200, 1.7e308])
def test_a_huge_damping_is_a_422_not_a_linear_algebra_crash(small, damping):
    client, pid, rid, *_ = small
    for robot, frame in [(pid, "arm"), ("ur5", "tool0"), (rid, "tool0")]:
        nq = 1 if robot != "ur5" else 6
        r = client.post(
            f"/v1/robots/{robot}/operational-space",
            json={"q": [0.1] * nq, "frame": frame, "damping": damping},
        )
        assert r.status_code == 422 and r.json()["code"] == "validation_error", r.text
        assert "damping" in r.json()["detail"]


def test_the_largest_allowed_damping_gives_a_finite_answer(small):
    client, *_ = small
    r = client.post(
        "/v1/robots/ur5/operational-space",
        json={"q": [0.1] * 6, "frame": "tool0", "damping": 1e150},
    )
    assert r.status_code == 200, r.text
    assert np.all(np.abs(r.json()["inertia"]) <= 1e-299)


def test_a_failed_solve_anywhere_is_a_singular_configuration(small, monkeypatch):
    """The one guard around every computation: a LinAlgError becomes a 422."""
    from service.dynamics import operational_space as module

    def failing(*args, **kwargs):
        raise np.linalg.LinAlgError("Eigenvalues did not converge")

    monkeypatch.setattr(module.np.linalg, "eigh", failing)
    client, *_ = small
    r = client.post("/v1/robots/ur5/operational-space", json={"q": [0.1] * 6, "frame": "tool0"})
    assert r.status_code == 422 and r.json()["code"] == "singular_configuration"
    assert "did not converge" in r.json()["detail"]


RAGGED_TAU = [[0.0] * 6, [0.0] * 5, [0.0] * 6]


def test_a_ragged_torque_schedule_is_a_422(small):
    client, *_ = small
    r = client.post(
        "/v1/robots/ur5/simulate",
        json={"q": [0.0] * 6, "v": [0.0] * 6, "dt": 0.01, "steps": 3, "tau": RAGGED_TAU},
    )
    assert r.status_code == 422 and r.json()["code"] == "validation_error", r.text
    assert "tau" in r.json()["detail"]


def test_a_ragged_torque_schedule_on_the_stream_is_a_problem(small):
    client, *_ = small
    with client.websocket_connect("/v1/robots/ur5/stream") as ws:
        ws.send_text(
            orjson.dumps(
                {
                    "quantity": "simulate",
                    "q": [0.0] * 6,
                    "v": [0.0] * 6,
                    "dt": 0.01,
                    "steps": 3,
                    "tau": RAGGED_TAU,
                }
            ).decode()
        )
        problem = ws.receive_json()
        assert problem["status"] == 422 and problem["code"] == "validation_error"
        ws.send_text(orjson.dumps({"quantity": "gravity", "q": [0.0] * 6}).decode())
        assert len(ws.receive_json()["gravity"]) == 6  # the stream stays open


def _binary_with_shape(shape: list, quantity: str | None = None) -> bytes:
    """A safetensors body whose tensor q declares `shape` (its data: the numbers that shape
    holds when it is small, else 6)."""
    count = math.prod(shape) if all(type(n) is int and 0 <= n < 64 for n in shape) else 6
    header: dict = {"q": {"dtype": "F64", "shape": shape, "data_offsets": [0, 8 * count]}}
    if quantity is not None:
        header["__metadata__"] = {"quantity": json.dumps(quantity)}
    raw = json.dumps(header).encode()
    raw += b" " * ((8 - len(raw) % 8) % 8)
    return len(raw).to_bytes(8, "little") + raw + bytes(8 * count)


@pytest.mark.parametrize(
    "shape",
    [
        [0, 2**63],
        [2**63, 0],
        [0, 2**62, 2**62],
        [0, 1 << 25],
        [1 << 25, 0, 1],
        [-1, 6],
        [True, 6],
        [6.0],
        [0, 2**64],
    ],
)
def test_a_binary_shape_beyond_the_bounds_is_a_422_before_any_allocation(small, shape):
    client, *_ = small
    r = client.post(
        "/v1/robots/ur5/gravity", content=_binary_with_shape(shape), headers={"Content-Type": BIN}
    )
    assert r.status_code == 422 and r.json()["code"] == "validation_error", r.text
    with client.websocket_connect("/v1/robots/ur5/stream") as ws:
        ws.send_bytes(_binary_with_shape(shape, "gravity"))
        problem = ws.receive_json()
        assert problem["status"] == 422 and problem["code"] == "validation_error"


def test_an_empty_binary_batch_within_the_bounds_is_still_answered_as_a_dimension_problem(small):
    client, *_ = small
    r = client.post(
        "/v1/robots/ur5/gravity", content=_binary_with_shape([0, 6]), headers={"Content-Type": BIN}
    )
    assert r.status_code == 422 and r.json()["code"] == "dimension_mismatch", r.text


FIXED_ONLY = PENDULUM.replace('type="revolute"', 'type="fixed"')


def test_a_model_without_a_moving_joint_is_refused_at_upload(small):
    """nv = 0: no dynamics, and Pinocchio's frame Jacobians crash the process on such a model
    — refused when built, whatever the format."""
    client, *_ = small
    no_joint_mjcf = (
        '<mujoco model="still"><worldbody><body name="b"><inertial pos="0 0 0" '
        'mass="1" diaginertia="0.1 0.1 0.1"/></body></worldbody></mujoco>'
    )
    for body in ({"urdf": FIXED_ONLY}, {"mjcf": no_joint_mjcf}):
        r = client.post("/v1/robots", json=body)
        assert r.status_code == 422 and r.json()["code"] == "invalid_model", r.text
        assert re.search("no (moving )?joint", r.json()["detail"])
    r = client.post("/v1/robots", json={"urdf": FIXED_ONLY, "root_joint": "free-flyer"})
    assert r.status_code == 201 and r.json()["nv"] == 6


def test_a_stored_model_without_a_moving_joint_is_not_served(tmp_path):
    from fastapi.testclient import TestClient

    from service.main import create_app
    from service.registry import Registry
    from service.settings import Settings

    model_id = "u-still"
    summary = {
        "id": model_id,
        "name": "still",
        "source": "upload",
        "nq": 0,
        "nv": 0,
        "root_joint": "fixed",
    }
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / f"{model_id}.json").write_text(
        json.dumps(
            {
                "id": model_id,
                "format": "urdf",
                "description": FIXED_ONLY,
                "root_joint": "fixed",
                "gravity": [0.0, 0.0, -9.81],
                "name": "still",
                "warnings": [],
                "summary": summary,
            }
        )
    )
    registry = Registry(tmp_path, ["ur5"])
    registry.load()
    with TestClient(
        create_app(Settings(data_dir=tmp_path), registry=registry), raise_server_exceptions=False
    ) as client:
        r = client.post(f"/v1/robots/{model_id}/jacobian", json={"q": [], "v": [], "frame": "arm"})
        assert r.status_code == 404 and r.json()["code"] == "robot_not_found"


def test_a_robot_whose_link_and_joint_share_names_can_be_reduced(tmp_path):
    """Pinocchio's own reduction fails on shared frame names (anymal_c: link and joint
    'LF_HAA'). M of the reduced robot is M of the base with the
    locked joint's row and column removed, at the locked value."""
    from fastapi.testclient import TestClient

    from service.main import create_app
    from service.registry import Registry
    from service.settings import Settings

    registry = Registry(tmp_path, ["anymal_c"])
    registry.load()
    base = registry.get("anymal_c")
    assert len({f.name for f in base.model.frames}) < base.model.nframes  # shared names
    with TestClient(
        create_app(Settings(data_dir=tmp_path), registry=registry), raise_server_exceptions=False
    ) as client:
        r = client.post("/v1/robots/anymal_c/reduce", json={"locked_joints": {"LF_HAA": 0.2}})
        assert r.status_code == 201, r.text
        reduced = r.json()
        assert reduced["nv"] == base.nv - 1
        base_names = [f["name"] for f in client.get("/v1/robots/anymal_c").json()["frames"]]
        assert "LF_HAA" in [f["name"] for f in reduced["frames"]]
        assert set(f["name"] for f in reduced["frames"]) == set(base_names)
        q = np.array(base.info()["neutral_configuration"])
        lf = base.model.joints[base.model.getJointId("LF_HAA")]
        q[lf.idx_q] = 0.2
        keep = [i for i in range(base.nq) if i != lf.idx_q]
        M = client.post(
            f"/v1/robots/{reduced['id']}/mass-matrix", json={"q": q[keep].tolist()}
        ).json()["mass_matrix"]
        M_base = pin.crba(base.model, base.model.createData(), q)
        keep_v = [i for i in range(base.nv) if i != lf.idx_v]
        np.testing.assert_allclose(M, M_base[np.ix_(keep_v, keep_v)], atol=1e-10)
        r = client.post(
            f"/v1/robots/{reduced['id']}/jacobian", json={"q": q[keep].tolist(), "frame": "LF_HFE"}
        )
        assert r.status_code == 200, r.text


def test_the_talos_legs_catalog_robot_can_be_reduced(tmp_path):
    """talos_legs is assembled joint by joint from talos; its lower velocity and effort bounds
    must follow, or Pinocchio's reduction refuses it."""
    from service.registry import Registry

    registry = Registry(tmp_path, ["talos_legs"])
    registry.load()
    robot, created = registry.reduce("talos_legs", {"leg_left_1_joint": [0.1]})
    assert created and robot.nv == registry.get("talos_legs").nv - 1
