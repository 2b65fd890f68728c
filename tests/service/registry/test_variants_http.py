"""POST /v1/robots/{id}/variants: a stored derived robot whose answers are its parent's with the
payloads (and locked joints), with `parent` and `modifications` in its RobotInfo; durable
across a restart, the same id from two servers, working after its parent is deleted."""

from __future__ import annotations

import numpy as np

from tests.helpers import planar_arm_urdf

Q = [0.2, -1.1, 1.3, -0.4, 0.6, 0.1]
TOOL = {"frame": "tool0", "mass": 3.0, "center_of_mass": [0.0, 0.0, 0.05]}
WRIST = {"frame": "wrist_2_link", "mass": 0.5, "inertia": np.diag([1e-3, 1e-3, 1e-3]).tolist()}


def test_a_variant_answers_as_its_parent_carrying_the_payloads(small_app_factory):
    api = small_app_factory(catalog="ur5")
    made = api.post(
        "/v1/robots/ur5/variants", json={"payloads": [TOOL, WRIST], "name": "ur5 holding a part"}
    )
    assert made.status_code == 201, made.text
    info = made.json()
    assert made.headers["location"] == f"/v1/robots/{info['id']}"
    assert info["id"].startswith("v-") and info["parent"] == "ur5"
    assert info["name"] == "ur5 holding a part" and info["source"] == "upload"
    assert [p["frame"] for p in info["modifications"]["payloads"]] == ["tool0", "wrist_2_link"]
    ur5 = api.get("/v1/robots/ur5").json()
    assert info["total_mass"] == info["moving_mass"]
    assert abs(info["total_mass"] - ur5["total_mass"] - 3.5) < 1e-12
    assert info["fixed_mass"] == ur5["fixed_mass"] == 4.0
    again = api.post("/v1/robots/ur5/variants", json={"payloads": [WRIST, TOOL]})
    assert again.status_code == 200 and again.json()["id"] == info["id"]
    for quantity, body in (
        ("gravity", {"q": Q}),
        ("mass-matrix", {"q": Q}),
        ("payload-capacity", {"q": Q, "frame": "tool0"}),
    ):
        on_variant = api.post(f"/v1/robots/{info['id']}/{quantity}", json=body).json()
        carried = api.post(
            f"/v1/robots/ur5/{quantity}", json={**body, "payloads": [TOOL, WRIST]}
        ).json()
        assert on_variant == carried, quantity
    listed = {r["id"] for r in api.get("/v1/robots").json()["robots"]}
    assert info["id"] in listed


def test_variants_survive_a_restart_and_get_the_same_id_everywhere(small_app_factory, tmp_path):
    one = small_app_factory(tmp_path / "a", catalog="ur5")
    two = small_app_factory(tmp_path / "b", catalog="ur5")
    body = {"payloads": [TOOL], "locked_joints": {"wrist_3_joint": 0.2}}
    first = one.post("/v1/robots/ur5/variants", json=body).json()
    assert two.post("/v1/robots/ur5/variants", json=body).json()["id"] == first["id"]
    assert first["nv"] == 5 and first["modifications"]["locked_joints"] == {"wrist_3_joint": [0.2]}
    g = one.post(f"/v1/robots/{first['id']}/gravity", json={"q": Q[:5]}).json()
    restarted = small_app_factory(tmp_path / "a", catalog="ur5")
    assert restarted.get(f"/v1/robots/{first['id']}").json() == first
    assert restarted.post(f"/v1/robots/{first['id']}/gravity", json={"q": Q[:5]}).json() == g


def test_deleting_the_parent_leaves_the_variant_working(small_app_factory, tmp_path):
    api = small_app_factory(tmp_path, catalog="ur5")
    arm = api.post("/v1/robots", json={"urdf": planar_arm_urdf(0.7, 0.5, 1.5, 0.8)}).json()
    tip = {"frame": "link2", "mass": 2.0, "center_of_mass": [0.5, 0.0, 0.0]}
    variant = api.post(f"/v1/robots/{arm['id']}/variants", json={"payloads": [tip]}).json()
    nested = api.post(
        f"/v1/robots/{variant['id']}/variants", json={"locked_joints": {"elbow": 0.3}}
    ).json()
    assert nested["id"].startswith("r-") and nested["parent"] == variant["id"]
    q = [0.4, 0.3]
    g = api.post(f"/v1/robots/{variant['id']}/gravity", json={"q": q}).json()["gravity"]
    # the same arm with the mass at its tip, uploaded: the same gravity torques
    heavier = api.post("/v1/robots", json={"urdf": planar_arm_urdf(0.7, 0.5, 1.5, 2.8)}).json()
    want = api.post(f"/v1/robots/{heavier['id']}/gravity", json={"q": q}).json()["gravity"]
    np.testing.assert_allclose(g, want, rtol=1e-12)
    assert api.delete(f"/v1/robots/{arm['id']}").status_code == 204
    assert api.get(f"/v1/robots/{arm['id']}").status_code == 404
    assert api.post(f"/v1/robots/{variant['id']}/gravity", json={"q": q}).json()["gravity"] == g
    restarted = small_app_factory(tmp_path, catalog="ur5")
    assert (
        restarted.post(f"/v1/robots/{variant['id']}/gravity", json={"q": q}).json()["gravity"] == g
    )
    shoulder = restarted.post(f"/v1/robots/{nested['id']}/gravity", json={"q": q[:1]}).json()
    assert abs(shoulder["gravity"][0] - g[0]) < 1e-12  # the elbow locked where q had it


def test_locked_joints_alone_is_reduce(small_app_factory):
    api = small_app_factory(catalog="ur5")
    body = {"locked_joints": {"elbow_joint": -1.0}}
    reduced = api.post("/v1/robots/ur5/reduce", json=body).json()
    variant = api.post("/v1/robots/ur5/variants", json=body)
    assert variant.status_code == 200 and variant.json()["id"] == reduced["id"]
    assert reduced["id"].startswith("r-") and reduced["parent"] == "ur5"
    assert reduced["modifications"] == {"locked_joints": {"elbow_joint": [-1.0]}}


def test_variant_mistakes_are_named_4xx(small_app_factory):
    api = small_app_factory(catalog="ur5")
    for robot, body, status, code in [
        ("ur5", {}, 422, "validation_error"),
        ("ur5", {"payloads": []}, 422, "validation_error"),
        ("ur5", {"locked_joints": {"elbow": 0.1}}, 422, "validation_error"),
        ("ur5", {"locked_joints": {"elbow_joint": 9.0}}, 422, "invalid_configuration"),
        ("ur5", {"payloads": [{"frame": "tool9", "mass": 1.0}]}, 422, "unknown_frame"),
        ("ur5", {"payloads": [TOOL], "colour": "red"}, 422, "validation_error"),
        ("nope", {"payloads": [TOOL]}, 404, "robot_not_found"),
    ]:
        r = api.post(f"/v1/robots/{robot}/variants", json=body)
        assert (r.status_code, r.json()["code"]) == (status, code), (body, r.text)


def test_a_real_server_restarted_on_its_data_serves_the_variant(tmp_path):
    """`python -m service` stores a variant; a second process on the same data directory (a
    restart, or a replica) serves it with the same answers, and finds it again by its id."""
    import httpx

    from tests.servers import running_server

    body = {"payloads": [TOOL, WRIST], "name": "ur5 with a tool"}
    with running_server(tmp_path / "data", catalog="ur5") as url:
        made = httpx.post(f"{url}/v1/robots/ur5/variants", json=body)
        assert made.status_code == 201, made.text
        g = httpx.post(f"{url}/v1/robots/{made.json()['id']}/gravity", json={"q": Q}).json()
    with running_server(tmp_path / "data", catalog="ur5") as url:
        info = httpx.get(f"{url}/v1/robots/{made.json()['id']}").json()
        assert info == made.json()
        assert httpx.post(f"{url}/v1/robots/{info['id']}/gravity", json={"q": Q}).json() == g
        again = httpx.post(f"{url}/v1/robots/ur5/variants", json=body)
        assert again.status_code == 200 and again.json()["id"] == info["id"]
