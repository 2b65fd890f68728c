"""Health, metrics and the OpenAPI document."""

from __future__ import annotations

import re


def test_health(api):
    assert api.get("/health/live").json() == {"status": "ok"}
    ready = api.get("/health/ready")
    assert ready.status_code == 200 and ready.json()["status"] == "ready"


def test_metrics_count_requests_by_route_and_robot(api):
    api.post("/v1/robots/ur5/gravity", json={"q": [0] * 6})
    api.post("/v1/robots/ur5/gravity", json={"q": [0] * 5})
    text = api.get("/metrics").text
    ok = re.search(
        r'robodyn_requests_total\{method="POST",robot="ur5",'
        r'route="/v1/robots/\{robot_id\}/gravity",status="200"\} (\d+)',
        text,
    )
    bad = re.search(
        r'robodyn_requests_total\{method="POST",robot="ur5",'
        r'route="/v1/robots/\{robot_id\}/gravity",status="422"\} (\d+)',
        text,
    )
    assert ok and int(float(ok.group(1))) >= 1
    assert bad and int(float(bad.group(1))) >= 1
    assert 'robodyn_request_duration_seconds_bucket{le="0.001",method="POST",robot="ur5"' in text


def test_openapi_documents_every_route_with_units(api):
    doc = api.get("/openapi.json").json()
    paths = doc["paths"]
    for quantity in (
        "mass-matrix",
        "gravity",
        "coriolis",
        "nonlinear-effects",
        "inverse-dynamics",
        "forward-dynamics",
    ):
        assert "post" in paths[f"/v1/robots/{{robot_id}}/{quantity}"]
    assert {"get", "post"} <= set(paths["/v1/robots"])
    assert {"get", "delete"} <= set(paths["/v1/robots/{robot_id}"])
    assert "/health/live" in paths and "/health/ready" in paths and "/metrics" in paths
    schemas = doc["components"]["schemas"]
    q_desc = schemas["QRequest"]["properties"]["q"]["description"]
    assert "nq" in q_desc and "rad" in q_desc and "qw" in q_desc
    assert "N·m" in schemas["QVTauRequest"]["properties"]["tau"]["description"]
    assert "kg" in schemas["MassMatrixAnswer"]["properties"]["mass_matrix"]["description"]


def test_robot_info_layout(api):
    info = api.get("/v1/robots/talos").json()
    assert info["nq"] == 39 and info["nv"] == 38 and info["root_joint"] == "free-flyer"
    root = info["joints"][0]
    assert (root["name"], root["type"], root["idx_q"], root["nq"], root["idx_v"], root["nv"]) == (
        "root_joint",
        "free_flyer",
        0,
        7,
        0,
        6,
    )
    assert root["lower"] == [-1.0] * 7 and root["upper"] == [1.0] * 7  # as the loader set them
    assert info["joints"][1]["idx_q"] == 7 and info["joints"][1]["idx_v"] == 6
    assert "half_sitting" in info["reference_configurations"]
    assert info["default_configuration"] == info["reference_configurations"]["half_sitting"]
    assert len(info["neutral_configuration"]) == 39
    assert max(j["armature"][0] for j in info["joints"][1:]) > 0  # rotor inertia × gear ratio²
    assert 80 < info["total_mass"] < 100
    summary = {r["id"]: r for r in api.get("/v1/robots").json()["robots"]}["talos"]
    assert summary == {k: info[k] for k in summary}


def test_continuous_joint_layout(api):
    info = api.get("/v1/robots/double_pendulum_continuous").json()
    assert info["nq"] == 4 and info["nv"] == 2
    assert [(j["type"], j["nq"], j["nv"]) for j in info["joints"]] == [
        ("continuous", 2, 1),
        ("continuous", 2, 1),
    ]


def test_catalog_findings_are_warnings(api):
    pr2 = api.get("/v1/robots/pr2").json()
    assert any(
        w["code"] == "triangle_inequality" and w["element"] == "link" and w["name"] in w["message"]
        for w in pr2["warnings"]
    )


def test_continuous_joints_have_no_position_limits(api):
    joints = api.get("/v1/robots/double_pendulum_continuous").json()["joints"]
    assert all(j["lower"] == [None, None] and j["upper"] == [None, None] for j in joints)
