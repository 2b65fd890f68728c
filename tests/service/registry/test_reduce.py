"""Reduced models: M of the reduced robot is the free-joint block of the full M at the locked
values (over HTTP, for arms and free-flyers), RobotInfo is complete, ids are content-derived and
durable, and every client mistake is a named 4xx."""

from __future__ import annotations

import re

import numpy as np
import pytest
from fastapi.testclient import TestClient

from service.registry import Registry
from tests.helpers import planar_arm_urdf, random_configuration

LEAK = re.compile(r"Traceback|\.hxx|\.hpp|\.cpp|\.py\b|/usr/|/work/|site-packages|File \"")
TOL = 1e-9
FF_POSE = [0.1, -0.2, 0.3, 0.0, 0.0, 0.38268343236508984, 0.9238795325112867]

CASES = {  # robot, locked joints (values as a user sends them)
    "ur5-wrist-elbow": ("ur5", {"wrist_1_joint": 0.3, "elbow_joint": -1.0}),
    "panda-fingers-wrist": (
        "panda",
        {"panda_joint7": 0.5, "panda_finger_joint1": 0.02, "panda_finger_joint2": [0.03]},
    ),
    "solo12-one-leg": ("solo12", {"FL_HAA": 0.1, "FL_HFE": 0.8, "FL_KFE": -1.6}),
    "solo12-base": ("solo12", {"root_joint": FF_POSE}),
    "talos-left-arm": ("talos", {f"arm_left_{i}_joint": -0.2 for i in (3, 5, 6, 7)}),
    "pendulum-angle": ("double_pendulum_continuous", {"joint1": 0.7}),
    "pendulum-pair": ("double_pendulum_continuous", {"joint1": [np.cos(0.7), np.sin(0.7)]}),
}


def _post(api: TestClient, path: str, body: dict) -> dict:
    r = api.post(path, json=body)
    assert r.status_code in (200, 201), r.text
    return r.json()


def _layout(base: dict, reduced: dict) -> tuple[list[int], list[int]]:
    """Indices into the base's q and v of the reduced robot's q and v entries."""
    joints = {j["name"]: j for j in base["joints"]}
    q_index, v_index = [], []
    for j in reduced["joints"]:
        b = joints[j["name"]]
        assert (b["nq"], b["nv"]) == (j["nq"], j["nv"])
        q_index += range(b["idx_q"], b["idx_q"] + b["nq"])
        v_index += range(b["idx_v"], b["idx_v"] + b["nv"])
    return q_index, v_index


@pytest.mark.parametrize("case", sorted(CASES))
def test_reduced_dynamics_are_the_free_block_of_the_full_ones(
    api: TestClient, catalog_registry: Registry, case: str
) -> None:
    robot, locked = CASES[case]
    info = _post(api, f"/v1/robots/{robot}/reduce", {"locked_joints": locked})
    base = api.get(f"/v1/robots/{robot}").json()
    q_index, v_index = _layout(base, info)
    assert info["nv"] == len(v_index) < base["nv"] and info["nq"] == len(q_index)
    model = catalog_registry.get(robot).model
    rng = np.random.default_rng(hash(case) % 2**32)
    q = np.array([random_configuration(model, rng) for _ in range(5)])
    for joint, values in info["reduced_from"]["locked_joints"].items():
        spec = next(j for j in base["joints"] if j["name"] == joint)
        q[:, spec["idx_q"] : spec["idx_q"] + spec["nq"]] = values
    v, a = np.zeros((5, base["nv"])), np.zeros((5, base["nv"]))
    v[:, v_index] = rng.normal(size=(5, len(v_index)))
    a[:, v_index] = rng.normal(size=(5, len(v_index)))
    full = {"q": q, "v": v, "a": a}
    reduced = {"q": q[:, q_index], "v": v[:, v_index], "a": a[:, v_index]}
    for quantity, inputs, key, block in (
        ("mass-matrix", "q", "mass_matrix", np.ix_(range(5), v_index, v_index)),
        ("gravity", "q", "gravity", (slice(None), v_index)),
        ("nonlinear-effects", "qv", "nonlinear_effects", (slice(None), v_index)),
        ("inverse-dynamics", "qva", "tau", (slice(None), v_index)),
    ):
        want = np.array(
            _post(api, f"/v1/robots/{robot}/{quantity}", {k: full[k].tolist() for k in inputs})[key]
        )[block]
        got = np.array(
            _post(
                api, f"/v1/robots/{info['id']}/{quantity}", {k: reduced[k].tolist() for k in inputs}
            )[key]
        )
        np.testing.assert_allclose(got, want, rtol=TOL, atol=TOL, err_msg=quantity)


def test_reduced_robot_info_is_complete(api: TestClient) -> None:
    locked = {f"arm_left_{i}_joint": -0.25 for i in (3, 5, 6, 7)}
    info = _post(api, "/v1/robots/talos/reduce", {"locked_joints": locked, "name": "talos-7"})
    base = api.get("/v1/robots/talos").json()
    q_index, _ = _layout(base, info)
    assert info["source"] == "upload" and info["id"].startswith("r-") and info["name"] == "talos-7"
    assert info["root_joint"] == "free-flyer" and info["gravity"] == base["gravity"]
    assert info["total_mass"] == pytest.approx(base["total_mass"], rel=1e-12)
    assert info["warnings"] == base["warnings"]
    kept = [j for j in base["joints"] if j["name"] not in locked]
    assert [j["name"] for j in info["joints"]] == [j["name"] for j in kept]
    fields = ("type", "lower", "upper", "velocity_limit", "effort_limit", "armature")
    for mine, theirs in zip(info["joints"], kept, strict=True):
        assert {f: mine[f] for f in fields} == {f: theirs[f] for f in fields}
    assert any(a > 0 for j in info["joints"] for a in j["armature"])  # rotor inertia carried
    for name, q in base["reference_configurations"].items():
        np.testing.assert_array_equal(info["reference_configurations"][name], np.array(q)[q_index])
    np.testing.assert_array_equal(
        info["default_configuration"], np.array(base["default_configuration"])[q_index]
    )
    assert len(info["neutral_configuration"]) == info["nq"] == base["nq"] - 4
    assert info["reduced_from"] == {"robot": "talos", "locked_joints": {k: [-0.25] for k in locked}}
    assert {f["name"] for f in base["frames"]} == {f["name"] for f in info["frames"]}
    assert api.get(f"/v1/robots/{info['id']}").json() == info
    assert info["id"] in {r["id"] for r in api.get("/v1/robots").json()["robots"]}


def test_locking_the_free_flyer_gives_a_fixed_base(api: TestClient) -> None:
    info = _post(api, "/v1/robots/solo12/reduce", {"locked_joints": {"root_joint": FF_POSE}})
    assert info["root_joint"] == "fixed" and info["nq"] == info["nv"] == 12
    assert info["joints"][0]["parent"] == "universe"


def test_ids_are_content_derived_and_idempotent(api: TestClient, small_app_factory) -> None:
    body = {"locked_joints": {"wrist_1_joint": 0.3, "elbow_joint": -1.0}}
    first = api.post("/v1/robots/ur5/reduce", json=body)
    again = api.post(
        "/v1/robots/ur5/reduce",
        json={
            "locked_joints": {"elbow_joint": [-1.0], "wrist_1_joint": 0.3},
            "name": "another label",
        },
    )
    other = api.post("/v1/robots/ur5/reduce", json={"locked_joints": {"elbow_joint": -1.1}})
    assert first.status_code in (200, 201) and again.status_code == 200
    assert first.json()["id"] == again.json()["id"] != other.json()["id"]
    assert again.headers["location"] == f"/v1/robots/{again.json()['id']}"
    elsewhere = small_app_factory(catalog="ur5").post("/v1/robots/ur5/reduce", json=body)
    assert elsewhere.status_code == 201 and elsewhere.json()["id"] == first.json()["id"]


def test_reducing_a_reduced_model(api: TestClient) -> None:
    once = _post(api, "/v1/robots/ur5/reduce", {"locked_joints": {"wrist_1_joint": 0.3}})
    twice = _post(api, f"/v1/robots/{once['id']}/reduce", {"locked_joints": {"elbow_joint": -1.0}})
    both = _post(
        api, "/v1/robots/ur5/reduce", {"locked_joints": {"wrist_1_joint": 0.3, "elbow_joint": -1.0}}
    )
    assert twice["reduced_from"]["robot"] == once["id"] and twice["id"] != both["id"]
    assert [j["name"] for j in twice["joints"]] == [j["name"] for j in both["joints"]]
    q = [[0.1, -0.5, 0.2, 0.4], [1.0, 0.3, -0.7, 2.0]]
    M2 = _post(api, f"/v1/robots/{twice['id']}/mass-matrix", {"q": q})["mass_matrix"]
    M1 = _post(api, f"/v1/robots/{both['id']}/mass-matrix", {"q": q})["mass_matrix"]
    np.testing.assert_allclose(M2, M1, rtol=1e-12, atol=1e-12)


def _problem(r, status: int, code: str) -> str:
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    body = r.json()
    assert body["code"] == code and not LEAK.search(r.text), body
    return body["detail"]


def test_client_mistakes_are_named_4xx(api: TestClient, catalog_registry: Registry) -> None:
    stored = set(catalog_registry.store.ids())
    detail = _problem(
        api.post(
            "/v1/robots/ur5/reduce",
            json={"locked_joints": {"nope": 1, "ghost": [2], "elbow_joint": 0}},
        ),
        422,
        "validation_error",
    )
    assert "'nope'" in detail and "'ghost'" in detail and "GET /v1/robots/ur5" in detail
    detail = _problem(
        api.post("/v1/robots/ur5/reduce", json={"locked_joints": {"elbow_joint": 4.0}}),
        422,
        "invalid_configuration",
    )
    assert "elbow_joint" in detail and "3.14159265" in detail
    everything = {
        j: 0.0
        for j in (
            "shoulder_pan_joint",
            "shoulder_lift_joint",
            "elbow_joint",
            "wrist_1_joint",
            "wrist_2_joint",
            "wrist_3_joint",
        )
    }
    detail = _problem(
        api.post("/v1/robots/ur5/reduce", json={"locked_joints": everything}), 422, "invalid_model"
    )
    assert "nothing to move" in detail
    _problem(
        api.post(
            "/v1/robots/ur5/reduce",
            content=b'{"locked_joints": {"elbow_joint": NaN}}',
            headers={"content-type": "application/json"},
        ),
        422,
        "validation_error",
    )
    detail = _problem(
        api.post("/v1/robots/ur5/reduce", json={"locked_joints": {"elbow_joint": [1, 2]}}),
        422,
        "validation_error",
    )
    assert "revolute" in detail and "a number" in detail
    detail = _problem(
        api.post(
            "/v1/robots/solo12/reduce",
            json={"locked_joints": {"root_joint": [0, 0, 0, 0, 0, 0, 2]}},
        ),
        422,
        "invalid_configuration",
    )
    assert "quaternion" in detail and "norm" in detail
    _problem(api.post("/v1/robots/ur5/reduce", json={"locked_joints": {}}), 422, "validation_error")
    _problem(
        api.post("/v1/robots/ur5/reduce", json={"locked": {"elbow_joint": 0}}),
        422,
        "validation_error",
    )
    _problem(
        api.post("/v1/robots/nope/reduce", json={"locked_joints": {"j": 0}}), 404, "robot_not_found"
    )
    assert set(catalog_registry.store.ids()) == stored


def test_deleting_a_reduced_model(api: TestClient) -> None:
    info = _post(api, "/v1/robots/ur5/reduce", {"locked_joints": {"wrist_3_joint": 1.25}})
    assert api.delete(f"/v1/robots/{info['id']}").status_code == 204
    assert api.get(f"/v1/robots/{info['id']}").status_code == 404
    assert api.delete(f"/v1/robots/{info['id']}").status_code == 404
    assert api.get("/v1/robots/ur5").status_code == 200


def test_reduced_models_survive_a_restart_and_their_base_deletion(
    small_app_factory, tmp_path
) -> None:
    client = small_app_factory(data_dir=tmp_path, catalog="ur5,planar_arm")
    arm = _post(client, "/v1/robots", {"urdf": planar_arm_urdf(0.9, 0.6, 1.2, 0.8)})
    of_arm = _post(client, f"/v1/robots/{arm['id']}/reduce", {"locked_joints": {"elbow": 0.4}})
    of_ur5 = _post(client, "/v1/robots/ur5/reduce", {"locked_joints": {"elbow_joint": -1.0}})
    of_of = _post(
        client, f"/v1/robots/{of_ur5['id']}/reduce", {"locked_joints": {"wrist_2_joint": 0.5}}
    )
    q_arm, q_ur5 = [[0.3]], [[0.1, 0.2, 0.3, 0.4, 0.5]]
    before = [
        _post(client, f"/v1/robots/{i['id']}/mass-matrix", {"q": q})
        for i, q in ((of_arm, q_arm), (of_ur5, q_ur5), (of_of, [q_ur5[0][:4]]))
    ]
    assert client.delete(f"/v1/robots/{arm['id']}").status_code == 204
    # a restarted server on the same directory, serving a catalog without ur5
    restarted = small_app_factory(data_dir=tmp_path, catalog="planar_arm")
    assert restarted.get(f"/v1/robots/{arm['id']}").status_code == 404
    for info, q, M in zip(
        (of_arm, of_ur5, of_of), (q_arm, q_ur5, [q_ur5[0][:4]]), before, strict=True
    ):
        assert restarted.get(f"/v1/robots/{info['id']}").json() == info
        assert _post(restarted, f"/v1/robots/{info['id']}/mass-matrix", {"q": q}) == M
    listed = {r["id"] for r in restarted.get("/v1/robots").json()["robots"]}
    assert {of_arm["id"], of_ur5["id"], of_of["id"]} <= listed


def test_upload_with_locked_joints_is_the_reduction_of_the_upload(small_app_factory) -> None:
    client = small_app_factory(catalog="planar_arm")
    urdf = planar_arm_urdf(1.0, 0.5, 2.0, 1.0)
    direct = client.post("/v1/robots", json={"urdf": urdf, "locked_joints": {"shoulder": 0.2}})
    assert direct.status_code == 201, direct.text
    assert {r["id"] for r in client.get("/v1/robots").json()["robots"]} >= {direct.json()["id"]}
    assert direct.json()["nq"] == 1 and direct.json()["name"] == "arm_1.0_0.5_2.0_1.0 (reduced)"
    base = _post(client, "/v1/robots", {"urdf": urdf})
    assert base["nq"] == 2 and base["id"] == direct.json()["reduced_from"]["robot"]
    later = client.post(
        f"/v1/robots/{base['id']}/reduce", json={"locked_joints": {"shoulder": 0.2}}
    )
    assert later.status_code == 200 and later.json()["id"] == direct.json()["id"]
    bad = client.post("/v1/robots", json={"urdf": urdf, "locked_joints": {"knee": 0.2}})
    assert _problem(bad, 422, "validation_error").startswith("robot 'u-")


def test_reduce_needs_the_api_key_where_keys_are_set(small_app_factory) -> None:
    client = small_app_factory(catalog="ur5", api_keys="k1")
    body = {"locked_joints": {"elbow_joint": 0.5}}
    _problem(client.post("/v1/robots/ur5/reduce", json=body), 401, "unauthorized")
    ok = client.post("/v1/robots/ur5/reduce", json=body, headers={"authorization": "Bearer k1"})
    assert ok.status_code == 201
