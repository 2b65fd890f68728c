"""Uploads: content-derived ids, idempotence, durability across restarts and processes."""

from __future__ import annotations

import numpy as np
from fastapi.testclient import TestClient

from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.helpers import planar_arm_urdf

URDF = planar_arm_urdf(0.9, 0.6, 1.2, 0.8)


def _app(data_dir, catalog="ur5"):
    registry = Registry(data_dir, catalog.split(","))
    registry.load()
    return TestClient(create_app(Settings(data_dir=data_dir), registry=registry))


def test_upload_is_idempotent_with_a_content_id(tmp_path):
    client = _app(tmp_path)
    first = client.post("/v1/robots", json={"urdf": URDF})
    assert first.status_code == 201
    again = client.post("/v1/robots", json={"urdf": URDF})
    assert again.status_code == 200 and again.json()["id"] == first.json()["id"]
    assert first.headers["location"] == f"/v1/robots/{first.json()['id']}"
    # a different root joint or gravity is a different model
    # (free-flyer would be rejected: point masses on a line leave one rotation without inertia)
    ff = client.post("/v1/robots", json={"urdf": URDF, "root_joint": "planar"})
    moon = client.post("/v1/robots", json={"urdf": URDF, "gravity": [0, 0, -1.62]})
    assert ff.status_code == moon.status_code == 201, ff.text
    assert len({first.json()["id"], ff.json()["id"], moon.json()["id"]}) == 3
    assert ff.json()["nq"] == 6 and ff.json()["nv"] == 5
    assert ff.json()["joints"][0]["type"] == "planar"
    g_moon = client.post(f"/v1/robots/{moon.json()['id']}/gravity", json={"q": [0, 0]}).json()
    g_earth = client.post(f"/v1/robots/{first.json()['id']}/gravity", json={"q": [0, 0]}).json()
    np.testing.assert_allclose(
        np.array(g_moon["gravity"]) / 1.62, np.array(g_earth["gravity"]) / 9.81, rtol=1e-12
    )


def test_same_upload_same_id_on_another_machine(tmp_path):
    a = _app(tmp_path / "a").post("/v1/robots", json={"urdf": URDF}).json()["id"]
    b = _app(tmp_path / "b").post("/v1/robots", json={"urdf": URDF}).json()["id"]
    assert a == b


def test_uploads_survive_a_restart(tmp_path):
    client = _app(tmp_path)
    info = client.post("/v1/robots", json={"urdf": URDF, "name": "kept"}).json()
    q = [0.3, -0.4]
    before = client.post(f"/v1/robots/{info['id']}/mass-matrix", json={"q": q}).json()
    client.close()

    restarted = _app(tmp_path)  # a new process on the same data directory
    listed = {r["id"]: r for r in restarted.get("/v1/robots").json()["robots"]}
    assert listed[info["id"]]["name"] == "kept" and listed[info["id"]]["source"] == "upload"
    assert restarted.get(f"/v1/robots/{info['id']}").json() == info
    after = restarted.post(f"/v1/robots/{info['id']}/mass-matrix", json={"q": q}).json()
    assert after == before


def test_replicas_sharing_a_directory_see_uploads_and_deletions(tmp_path):
    one, two = _app(tmp_path), _app(tmp_path)
    robot_id = one.post("/v1/robots", json={"urdf": URDF}).json()["id"]
    r = two.post(f"/v1/robots/{robot_id}/gravity", json={"q": [0.1, 0.2]})
    assert r.status_code == 200
    assert robot_id in {x["id"] for x in two.get("/v1/robots").json()["robots"]}
    assert two.delete(f"/v1/robots/{robot_id}").status_code == 204
    assert one.post(f"/v1/robots/{robot_id}/gravity", json={"q": [0.1, 0.2]}).status_code == 404
    assert one.delete(f"/v1/robots/{robot_id}").status_code == 404


def test_an_unreadable_record_is_skipped(tmp_path):
    client = _app(tmp_path)
    good = client.post("/v1/robots", json={"urdf": URDF}).json()["id"]
    (tmp_path / "models" / "u-broken.json").write_text("{not json")
    (tmp_path / "models" / ".tmp-partial.json").write_text('{"id": "half')
    restarted = _app(tmp_path)
    assert restarted.get(f"/v1/robots/{good}").status_code == 200
    assert restarted.get("/v1/robots/u-broken").status_code == 404
    assert restarted.get("/health/ready").status_code == 200


def test_free_flyer_with_a_rotation_without_inertia_is_rejected(tmp_path):
    r = _app(tmp_path).post("/v1/robots", json={"urdf": URDF, "root_joint": "free-flyer"})
    assert r.status_code == 422 and "positive definite" in r.json()["detail"]


def test_uploaded_model_is_built_out_of_process_and_checked(tmp_path):
    client = _app(tmp_path)
    # passes the XML checks but the mass matrix is singular: a joint that moves only a link
    # with mass but zero inertia about its own axis through its centre of mass
    urdf = """<robot name='spin'><link name='a'/><link name='b'><inertial><mass value='1'/>
      <inertia ixx='0' ixy='0' ixz='0' iyy='0' iyz='0' izz='0'/></inertial></link>
      <joint name='j' type='revolute'><parent link='a'/><child link='b'/><axis xyz='0 0 1'/>
      <limit lower='-1' upper='1' effort='1' velocity='1'/></joint></robot>"""
    r = client.post("/v1/robots", json={"urdf": urdf})
    assert r.status_code == 422 and r.json()["code"] == "invalid_model"
    assert "positive definite" in r.json()["detail"]
    assert not list((tmp_path / "models").glob("*.json"))


def test_a_joint_or_link_named_universe_is_refused_by_name(tmp_path):
    """Pinocchio's own joint 0 and world frame are named `universe`: a description's joint or
    link of that name could never be found by name (two frames match), so it is a 422."""
    client = _app(tmp_path)
    for kind, urdf in (
        ("joint", URDF.replace('"shoulder"', '"universe"')),
        ("link", URDF.replace('"link1"', '"universe"')),
    ):
        assert "universe" in urdf
        r = client.post("/v1/robots", json={"urdf": urdf})
        assert r.status_code == 422 and r.json()["code"] == "invalid_model", r.text
        assert r.json()["detail"].startswith(f"{kind} 'universe':"), r.json()["detail"]
    assert not list((tmp_path / "models").glob("*.json"))
