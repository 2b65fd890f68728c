"""Every error code of API.md, as RFC 9457 problem+json, with no traceback, path or echo."""

from __future__ import annotations

import json
import re

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient

from service.api.encoding import binary
from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.helpers import planar_arm_urdf

LEAK = re.compile(r"Traceback|\.hxx|\.hpp|\.cpp|\.py\b|/usr/|/work/|site-packages|File \"")


def inertia(ixx: float, iyy: float, izz: float) -> str:
    return f"<inertia ixx='{ixx}' ixy='0' ixz='0' iyy='{iyy}' iyz='0' izz='{izz}'/>"


def assert_problem(r, status: int, code: str) -> dict:
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    body = r.json()
    assert body["code"] == code and body["status"] == status
    assert body["type"] == "about:blank" and body["title"] and body["detail"]
    assert not LEAK.search(r.text), r.text
    return body


def test_robot_not_found_points_to_the_list(api):
    for r in (api.get("/v1/robots/nope"), api.post("/v1/robots/nope/gravity", json={"q": [0]})):
        body = assert_problem(r, 404, "robot_not_found")
        assert "GET /v1/robots" in body["detail"]


def test_catalog_robot_cannot_be_deleted(api):
    assert_problem(api.delete("/v1/robots/ur5"), 409, "catalog_robot")
    assert api.get("/v1/robots/ur5").status_code == 200


def test_delete_unknown_upload(api):
    assert_problem(api.delete("/v1/robots/u-0000"), 404, "robot_not_found")


@pytest.mark.parametrize(
    "raw",
    [
        '{"q": [0, 0, 0, 0, 0, NaN]}',
        '{"q": [0, 0, 0, 0, 0, Infinity]}',
        '{"q": [0, 0, 0, 0, 0, -Infinity]}',
        '{"q": [0, 0, 0, 0, 0, 1e400]}',
        '{"q": [0, 0, 0, 0, 0, "1"]}',
        '{"q": [0, 0, 0, 0, 0, true]}',
        '{"q": [0, 0, 0, 0, 0, null]}',
        '{"q": [[[0, 0, 0, 0, 0, 0]]]}',
        '{"q": [[0, 0, 0, 0, 0, 0], [0, 0]]}',
        '{"q": [0, 0, 0, [0], 0, 0]}',
        '{"q": 3}',
        "{}",
        '{"q": [0, 0, 0, 0, 0, 0], "extra": 1}',
        "[0, 0, 0, 0, 0, 0]",
        '{"q": [0, 0, 0',
        "",
    ],
)
def test_malformed_bodies_are_validation_errors(api, raw):
    r = api.post(
        "/v1/robots/ur5/gravity", content=raw, headers={"content-type": "application/json"}
    )
    assert_problem(r, 422, "validation_error")


def test_validation_error_names_the_field(api):
    body = assert_problem(
        api.post("/v1/robots/ur5/coriolis", json={"q": [0] * 6}), 422, "validation_error"
    )
    assert body["detail"] == "v: Field required"


def test_a_vector_without_the_panda_fingers_says_how_to_leave_them_out(api):
    """The Panda's 9 joints end with its two finger joints: 7 values name them and the ways to
    leave joints out (fill with names, a reduced model), and each way answers."""
    detail = assert_problem(
        api.post("/v1/robots/panda/gravity", json={"q": [0.1] * 7}), 422, "dimension_mismatch"
    )["detail"]
    assert "robot 'panda' has nq = 9" in detail
    assert "2 joint(s) are missing ('panda_finger_joint1', 'panda_finger_joint2'" in detail
    assert '"fill": "neutral"' in detail and "POST /v1/robots/panda/reduce" in detail
    arm = {f"panda_joint{i}": 0.1 for i in range(1, 8)}
    filled = api.post("/v1/robots/panda/gravity", json={"q": arm, "fill": "neutral"})
    full = api.post("/v1/robots/panda/gravity", json={"q": [0.1] * 7 + [0.0, 0.0]})
    assert filled.status_code == full.status_code == 200
    assert filled.json() == full.json()
    # more entries than joints, or a count that ends inside a joint: no joints to name
    detail = assert_problem(
        api.post("/v1/robots/panda/gravity", json={"q": [0.1] * 10}), 422, "dimension_mismatch"
    )["detail"]
    assert detail == "q has 10 entries; robot 'panda' has nq = 9"
    detail = assert_problem(
        api.post("/v1/robots/solo12/gravity", json={"q": [0.0] * 5}), 422, "dimension_mismatch"
    )["detail"]
    assert detail == "q has 5 entries; robot 'solo12' has nq = 19"


def test_dimension_mismatch_says_what_was_expected(api):
    body = assert_problem(
        api.post("/v1/robots/ur5/gravity", json={"q": [0] * 5}), 422, "dimension_mismatch"
    )
    assert body["detail"].startswith("q has 5 entries; robot 'ur5' has nq = 6; ")
    assert "('wrist_3_joint', in model order)" in body["detail"]
    body = assert_problem(
        api.post("/v1/robots/talos/coriolis", json={"q": [0] * 6 + [1] + [0] * 32, "v": [0] * 39}),
        422,
        "dimension_mismatch",
    )
    assert "nv = 38" in body["detail"]


def test_batch_problems_are_dimension_mismatches(api):
    one, two = [0.0] * 6, [[0.0] * 6] * 2
    assert_problem(
        api.post("/v1/robots/ur5/coriolis", json={"q": one, "v": two}), 422, "dimension_mismatch"
    )
    body = assert_problem(
        api.post("/v1/robots/ur5/coriolis", json={"q": two, "v": [[0.0] * 6] * 3}),
        422,
        "dimension_mismatch",
    )
    assert "q has 2" in body["detail"] and "v has 3" in body["detail"]
    assert_problem(
        api.post("/v1/robots/ur5/gravity", json={"q": [[0.0] * 5] * 2}), 422, "dimension_mismatch"
    )


def test_batch_limit(small_app_factory):
    client = small_app_factory(max_batch=3)
    assert client.post("/v1/robots/ur5/gravity", json={"q": [[0.0] * 6] * 3}).status_code == 200
    body = assert_problem(
        client.post("/v1/robots/ur5/gravity", json={"q": [[0.0] * 6] * 4}),
        422,
        "dimension_mismatch",
    )
    assert "limit is 3" in body["detail"]


def test_non_unit_quaternion_is_an_invalid_configuration(api):
    q = [0.0] * 39
    q[6] = 0.9  # qw of the free-flyer base
    body = assert_problem(
        api.post("/v1/robots/talos/gravity", json={"q": q}), 422, "invalid_configuration"
    )
    assert "root_joint" in body["detail"] and "q[3:7]" in body["detail"]
    batch = [[0, 0, 0, 0, 0, 0, 1.0] + [0.0] * 32, q]
    body = assert_problem(
        api.post("/v1/robots/talos/gravity", json={"q": batch}), 422, "invalid_configuration"
    )
    assert body["detail"].startswith("state 1:")


def test_continuous_joint_needs_unit_cos_sin(api):
    body = assert_problem(
        api.post("/v1/robots/double_pendulum_continuous/gravity", json={"q": [0.0, 1.0, 2.0, 0.0]}),
        422,
        "invalid_configuration",
    )
    assert "cos" in body["detail"]


def test_non_finite_result_is_a_clear_error(api, catalog_registry):
    # romeo's description has a massless moving subtree: M is singular, ABA divides by zero.
    robot = catalog_registry.catalog["romeo"]
    assert any(w["code"] == "massless_subtree" for w in robot.warnings)
    q = robot.info()["neutral_configuration"]
    body = assert_problem(
        api.post(
            "/v1/robots/romeo/forward-dynamics",
            json={"q": q, "v": [0.0] * robot.nv, "tau": [0.0] * robot.nv},
        ),
        422,
        "non_finite_result",
    )
    assert "forward-dynamics" in body["detail"]


@pytest.mark.parametrize(
    "urdf, fragment",
    [
        ("this is not xml", "not well-formed"),
        ("<robot name='x'><link name='a'/>", "not well-formed"),
        ("<model name='x'/>", "<model>"),
        ("<robot><link name='a'/></robot>", "no name"),
        ("<robot name='x'/>", "no <link>"),
        ("<robot name='x'><link name='a'/><link name='a'/></robot>", "twice"),
        ("<robot name='x'><link name='a'/><link name='b'/></robot>", "2 root links"),
        (
            "<robot name='x'><link name='a'/><joint name='j' type='revolute'><parent link='a'/>"
            "<child link='zz'/></joint></robot>",
            "'zz' does not exist",
        ),
        (
            "<robot name='x'><link name='a'/><link name='b'>"
            "<inertial><mass value='1'/></inertial>"
            "</link><joint name='j' type='hinge'><parent link='a'/><child link='b'/></joint>"
            "</robot>",
            "type 'hinge'",
        ),
        (
            "<robot name='x'><link name='a'/><link name='b'>"
            "<inertial><mass value='nan'/></inertial>"
            "</link><joint name='j' type='revolute'><parent link='a'/><child link='b'/></joint>"
            "</robot>",
            "link 'b' mass value must be finite",
        ),
        (
            "<robot name='x'><link name='a'/><link name='b'><inertial><mass value='heavy'/>"
            "</inertial></link><joint name='j' type='revolute'><parent link='a'/><child link='b'/>"
            "</joint></robot>",
            "link 'b' mass value is not a number",
        ),
        (
            "<robot name='x'><link name='a'/><link name='b'><inertial><mass value='-1'/></inertial>"
            "</link><joint name='j' type='revolute'><parent link='a'/><child link='b'/></joint>"
            "</robot>",
            "negative",
        ),
        (
            "<robot name='x'><link name='a'/><link name='b'>"
            "<inertial><mass value='1'/></inertial>"
            "</link><joint name='j' type='revolute'><parent link='a'/><child link='b'/>"
            "<axis xyz='0 0 0'/></joint></robot>",
            "axis is zero",
        ),
        (
            "<robot name='x'><link name='a'/><link name='b'/><joint name='j' type='revolute'>"
            "<parent link='a'/><child link='b'/></joint></robot>",
            "no mass",
        ),
        ("<!DOCTYPE r [<!ENTITY e 'x'>]><robot name='&e;'><link name='a'/></robot>", "DTD"),
        (
            f"<robot name='x'><link name='a'><inertial><mass value='1'/>{inertia(-1, 1, 1)}"
            "</inertial></link></robot>",
            "negative principal moment",
        ),
        (
            f"<robot name='x'><link name='a'><inertial><mass value='1'/>{inertia(1, 1, 5)}"
            "</inertial></link></robot>",
            "triangle inequality",
        ),
        (
            "<robot name='x'><link name='a'><inertial><mass value='1'/><inertia ixx='1'/>"
            "</inertial></link></robot>",
            "inertia ixy is missing",
        ),
    ],
)
def test_invalid_uploads_name_what_is_wrong(api, urdf, fragment):
    body = assert_problem(api.post("/v1/robots", json={"urdf": urdf}), 422, "invalid_model")
    assert fragment in body["detail"], body["detail"]


def test_inertia_findings_can_be_accepted_with_warn(api):
    urdf = (
        f"<robot name='odd'><link name='a'><inertial><mass value='1'/>{inertia(1, 1, 5)}"
        "</inertial></link></robot>"
    )
    body = assert_problem(api.post("/v1/robots", json={"urdf": urdf}), 422, "invalid_model")
    assert '"inertia_check": "warn"' in body["detail"]
    r = api.post(
        "/v1/robots", json={"urdf": urdf, "inertia_check": "warn", "root_joint": "free-flyer"}
    )
    assert r.status_code in (200, 201), r.text
    warnings = r.json()["warnings"]
    assert warnings[0]["code"] == "triangle_inequality" and warnings[0]["name"] == "a"


def test_payload_too_large(small_app_factory):
    client = small_app_factory(max_body_bytes=4096)
    body = assert_problem(
        client.post("/v1/robots", json={"urdf": "x" * 5000}), 413, "payload_too_large"
    )
    assert "4096" in body["detail"]

    def chunks():  # no Content-Length: the limit applies while streaming
        for _ in range(10):
            yield b" " * 1000

    r = client.post(
        "/v1/robots/ur5/gravity", content=chunks(), headers={"content-type": "application/json"}
    )
    assert_problem(r, 413, "payload_too_large")
    assert client.get("/health/live").status_code == 200


def test_api_keys_guard_uploads_and_deletions(small_app_factory):
    client = small_app_factory(api_keys="k1, k2")
    urdf = planar_arm_urdf(1.0, 1.0, 1.0, 1.0)
    r = client.post("/v1/robots", json={"urdf": urdf})
    assert_problem(r, 401, "unauthorized")
    assert r.headers["www-authenticate"].startswith("Bearer")
    assert_problem(
        client.post("/v1/robots", json={"urdf": urdf}, headers={"Authorization": "Bearer nope"}),
        401,
        "unauthorized",
    )
    assert_problem(
        client.post("/v1/robots", json={"urdf": urdf}, headers={"Authorization": "Basic k1"}),
        401,
        "unauthorized",
    )
    r = client.post("/v1/robots", json={"urdf": urdf}, headers={"Authorization": "Bearer k2"})
    assert r.status_code == 201
    robot_id = r.json()["id"]
    # compute, reads, health and metrics stay open
    assert client.post(f"/v1/robots/{robot_id}/gravity", json={"q": [0, 0]}).status_code == 200
    assert client.get("/v1/robots").status_code == 200
    assert client.get("/metrics").status_code == 200
    assert_problem(client.delete(f"/v1/robots/{robot_id}"), 401, "unauthorized")
    assert (
        client.delete(f"/v1/robots/{robot_id}", headers={"Authorization": "Bearer k1"}).status_code
        == 204
    )


def test_not_ready_before_the_catalog_is_loaded(tmp_path):
    registry = Registry(tmp_path, ["ur5"])  # not loaded
    with TestClient(create_app(Settings(data_dir=tmp_path), registry=registry)) as client:
        r = client.get("/health/ready")
        assert_problem(r, 503, "not_ready")
        assert r.headers["retry-after"] == "1"
        assert_problem(client.post("/v1/robots/ur5/gravity", json={"q": [0] * 6}), 503, "not_ready")
        assert client.get("/health/live").json() == {"status": "ok"}
        registry.load()
        assert client.get("/health/ready").status_code == 200


def test_overloaded_sheds_large_batches(small_app_factory):
    client = small_app_factory(max_pending_batches=1)
    client.app.state.batches_in_flight = 1  # as if one large batch were being computed
    q = np.zeros((400, 6)).tolist()
    r = client.post("/v1/robots/ur5/gravity", json={"q": q})
    assert_problem(r, 503, "overloaded")
    assert r.headers["retry-after"] == "1"
    assert client.post("/v1/robots/ur5/gravity", json={"q": [0] * 6}).status_code == 200
    client.app.state.batches_in_flight = 0
    assert client.post("/v1/robots/ur5/gravity", json={"q": q}).status_code == 200


def test_internal_errors_leak_nothing(tmp_path):
    class Broken(Registry):
        def get(self, robot_id):
            raise RuntimeError("From file: /usr/include/pinocchio/algorithm/rnea.hxx:42 boom")

    registry = Broken(tmp_path, ["ur5"])
    registry.load()
    app = create_app(Settings(data_dir=tmp_path), registry=registry)
    with TestClient(app, raise_server_exceptions=False) as client:
        r = client.post("/v1/robots/ur5/gravity", json={"q": [0] * 6})
        body = assert_problem(r, 500, "internal_error")
        assert "rnea" not in json.dumps(body)


def test_unknown_routes_and_methods_are_problems(api):
    assert_problem(api.get("/v2/nothing"), 404, "not_found")
    assert_problem(api.put("/v1/robots/ur5"), 405, "method_not_allowed")
    assert_problem(api.get("/v1/robots/ur5/gravity"), 405, "method_not_allowed")


def test_a_body_not_labelled_json_is_415(api):
    r = api.post(
        "/v1/robots/ur5/gravity",
        content=b'{"q": [0, 0, 0, 0, 0, 0]}',
        headers={"content-type": "application/x-www-form-urlencoded"},
    )
    body = assert_problem(r, 415, "unsupported_media_type")
    assert "application/json" in body["detail"]
    r = api.post("/v1/robots/ur5/gravity", content=b'{"q": [0, 0, 0, 0, 0, 0]}')
    assert r.status_code == 200  # no Content-Type at all: read as JSON


def test_media_types_are_read_regardless_of_case(api):
    """RFC 9110: type and subtype names are case-insensitive (and the first header counts)."""
    json_body = b'{"q": [0, 0, 0, 0, 0, 0]}'
    r = api.post(
        "/v1/robots/ur5/gravity",
        content=json_body,
        headers={"content-type": "Application/JSON; charset=UTF-8"},
    )
    assert r.status_code == 200 and r.headers["content-type"] == "application/json"
    binary_body = binary.encode({"q": np.zeros((1, 6))})
    r = api.post(
        "/v1/robots/ur5/gravity",
        content=binary_body,
        headers={
            "content-type": "Application/VND.Robodyn.SafeTensors",
            "accept": "APPLICATION/VND.ROBODYN.SAFETENSORS",
        },
    )
    assert r.status_code == 200 and r.headers["content-type"] == binary.BINARY_MEDIA_TYPE
    assert binary.decode(r.content)[1]["gravity"].shape == (1, 6)


def test_other_framework_4xx_are_bad_requests(api):
    from starlette.exceptions import HTTPException
    from starlette.requests import Request

    from service.api.problems.handlers import _on_http_error

    request = Request({"type": "http", "method": "GET", "path": "/", "headers": [], "app": api.app})
    import asyncio

    r = asyncio.run(_on_http_error(request, HTTPException(status_code=429, detail="slow down")))
    # a framework 4xx without a code of its own is a 400 bad_request, never a 500
    assert r.status_code == 400 and json.loads(r.body)["code"] == "bad_request"


def test_an_angle_far_outside_its_range_is_computed_with_a_warning(api, catalog_registry):
    """An elbow at 90 "rad" (degrees sent as radians): answered as given (it may be a state a
    simulation reached), with a `Robodyn-Warning` header naming the joint, its range and the
    angle in degrees; in a batch, the state. Within a turn of the range: no header."""
    q = [0.0, -1.2, 90.0, 0.0, 0.0, 0.0]
    r = api.post("/v1/robots/ur5/gravity", json={"q": q})
    assert r.status_code == 200
    model = catalog_registry.catalog["ur5"].model
    np.testing.assert_allclose(
        r.json()["gravity"], pin.computeGeneralizedGravity(model, model.createData(), np.array(q))
    )
    assert r.headers["robodyn-warning"] == (
        "q[2] = 90 rad, the angle of revolute joint 'elbow_joint', is 13.8 turns outside its "
        "range [-3.14159, 3.14159] rad; angles are in radians (90 degrees would be 1.5708 rad)"
    )
    batch = api.post("/v1/robots/ur5/gravity", json={"q": [[0.0] * 6, q]})
    assert batch.headers["robodyn-warning"].startswith("state 1: q[2] = 90 rad")
    near = api.post("/v1/robots/ur5/gravity", json={"q": [0.0, -1.2, 3.14 + 6.2, 0.0, 0.0, 0.0]})
    assert near.status_code == 200 and "robodyn-warning" not in near.headers
