"""Error answers of the frame, task-space and Lagrangian endpoints (jacobian,
operational-space, mass-matrix-inverse, energy, center-of-mass): unknown_frame,
singular_configuration, invalid options, and the frame list of RobotInfo they point to."""

from __future__ import annotations

import numpy as np
import pytest

from service.api.encoding import binary
from tests.service.api.problems.test_errors import assert_problem

Q = [0.3, -1.0, 1.2, -0.7, 1.1, 0.4]


@pytest.mark.parametrize("quantity", ["jacobian", "operational-space"])
def test_unknown_frame_points_to_the_frame_list(api, quantity):
    body = assert_problem(
        api.post(f"/v1/robots/ur5/{quantity}", json={"q": Q, "frame": "gripper"}),
        422,
        "unknown_frame",
    )
    assert body["detail"] == (
        "robot 'ur5' has no frame 'gripper'; the valid names are listed "
        "under `frames` of GET /v1/robots/ur5 (links, joints and fixed "
        "frames)"
    )
    # a long or unprintable name is not echoed back
    for name in ("x" * 300, "tool0\n\x00"):
        body = assert_problem(
            api.post(f"/v1/robots/ur5/{quantity}", json={"q": Q, "frame": name}),
            422,
            "unknown_frame",
        )
        assert "xxxx" not in body["detail"] and "\x00" not in body["detail"]
        assert "`frames` of GET /v1/robots/ur5" in body["detail"]


def test_unknown_frame_in_a_binary_body(api):
    content = binary.encode({"q": np.array(Q), "frame": "nope"})
    r = api.post(
        "/v1/robots/ur5/jacobian",
        content=content,
        headers={"content-type": binary.BINARY_MEDIA_TYPE},
    )
    assert_problem(r, 422, "unknown_frame")


def test_the_frame_list_is_in_robot_info_and_every_name_works(api):
    info = api.get("/v1/robots/ur5").json()
    frames = info["frames"]
    names = [f["name"] for f in frames]
    assert {"universe", "base_link", "shoulder_pan_joint", "tool0", "wrist_3_link"} <= set(names)
    assert {f["type"] for f in frames} <= {"body", "joint", "fixed_joint", "op_frame", "sensor"}
    joint_names = {j["name"] for j in info["joints"]} | {"universe"}
    assert all(f["parent_joint"] in joint_names for f in frames)
    # the frame carried by the universe does not move; frames on the last joint move with it
    for f in frames:
        J = np.asarray(
            api.post("/v1/robots/ur5/jacobian", json={"q": Q, "frame": f["name"]}).json()[
                "jacobian"
            ]
        )
        assert J.shape == (6, 6)
        assert (not J.any()) == (f["parent_joint"] == "universe"), f
    openapi = api.get("/openapi.json").json()
    schema = openapi["components"]["schemas"]["RobotInfo"]["properties"]["frames"]
    assert "frame" in schema["description"] and "valid names" in schema["description"]


def test_singular_configuration_is_a_problem(api):
    body = assert_problem(
        api.post("/v1/robots/ur5/operational-space", json={"q": [0.0] * 6, "frame": "tool0"}),
        422,
        "singular_configuration",
    )
    assert "damping" in body["detail"]
    condition = body["condition_number"]
    assert condition is None or condition >= 1e8
    assert body["smallest_singular_value"] <= 1e-8 * body["largest_singular_value"]


@pytest.mark.parametrize(
    ("body", "location"),
    [
        ({"frame": "tool0", "reference_frame": "base"}, "reference_frame"),
        ({"frame": "tool0", "reference_frame": "WORLD"}, "reference_frame"),
        ({"frame": "tool0", "task": "position"}, "task"),
        ({"frame": "tool0", "damping": -0.1}, "damping"),
        ({"frame": "tool0", "damping": "0.1"}, "damping"),
        ({"frame": "tool0", "damping": True}, "damping"),
        ({"frame": 3}, "frame"),
        ({"frame": ""}, "frame"),
        ({}, "frame"),
        ({"frame": "tool0", "gain": 1}, "gain"),
    ],
)
def test_invalid_options_are_validation_errors(api, body, location):
    r = api.post("/v1/robots/ur5/operational-space", json={"q": Q, **body})
    problem = assert_problem(r, 422, "validation_error")
    assert problem["detail"].startswith(location), problem["detail"]


def test_non_finite_damping_is_a_validation_error(api):
    r = api.post(
        "/v1/robots/ur5/operational-space",
        content=b'{"q": [0, 0, 0, 0, 0, 0], "frame": "tool0", "damping": NaN}',
        headers={"content-type": "application/json"},
    )
    assert_problem(r, 422, "validation_error")


@pytest.mark.parametrize(
    "quantity, extra",
    [
        ("jacobian", {"frame": "tool0"}),
        ("operational-space", {"frame": "tool0"}),
        ("center-of-mass", {}),
        ("energy", {}),
    ],
)
def test_optional_v_is_checked_like_any_input(api, quantity, extra):
    body = assert_problem(
        api.post(f"/v1/robots/ur5/{quantity}", json={"q": Q, "v": [0.0] * 5, **extra}),
        422,
        "dimension_mismatch",
    )
    assert body["detail"].startswith("v has 5 entries; robot 'ur5' has nv = 6; ")
    assert_problem(
        api.post(f"/v1/robots/ur5/{quantity}", json={"q": Q, "v": [[0.0] * 6] * 2, **extra}),
        422,
        "dimension_mismatch",
    )


def test_energy_needs_v(api):
    body = assert_problem(api.post("/v1/robots/ur5/energy", json={"q": Q}), 422, "validation_error")
    assert body["detail"] == "v: Field required"


@pytest.mark.parametrize(
    "quantity, extra", [("mass-matrix-inverse", {}), ("operational-space", {"frame": "l_wrist"})]
)
def test_singular_mass_matrix_is_a_non_finite_result(api, catalog_registry, quantity, extra):
    # romeo's description has a massless moving subtree: M is singular, M⁻¹ does not exist.
    robot = catalog_registry.catalog["romeo"]
    assert any(w["code"] == "massless_subtree" for w in robot.warnings)
    q = robot.info()["neutral_configuration"]
    body = assert_problem(
        api.post(f"/v1/robots/romeo/{quantity}", json={"q": q, **extra}), 422, "non_finite_result"
    )
    assert "mass_matrix_inverse" in body["detail"]


def test_unknown_robot(api):
    for r in (
        api.get("/v1/robots/nope/inertias"),
        api.post("/v1/robots/nope/operational-space", json={"q": Q, "frame": "tool0"}),
    ):
        assert_problem(r, 404, "robot_not_found")
    assert_problem(api.post("/v1/robots/ur5/inertias", json={}), 405, "method_not_allowed")
