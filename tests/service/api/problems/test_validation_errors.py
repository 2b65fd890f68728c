"""Validation errors read like the request: one entry per mistake, union members resolved,
and unknown names answered with close matches."""

from __future__ import annotations

import pytest

from service.errors import did_you_mean
from tests.service.api.problems.test_errors import assert_problem

Q = [0.0, -1.0, 1.0, 0.0, 0.0, 0.0]
INTERNAL = ("dict[", "list[", "constrained", "union[", "function-")


@pytest.mark.parametrize(
    ("body", "loc", "msg"),
    [
        (
            {"q": "abc"},
            "q",
            "must be an array of numbers, an array of arrays of numbers, an object "
            "or an array of objects",
        ),
        ({"q": None}, "q", "must be an array of numbers"),
        ({"q": [0, 0, "x", 0, 0, 0]}, "q[2]", "must be a valid number"),
        ({"q": [0, 0, True, 0, 0, 0]}, "q[2]", "must be a valid number"),
        ({"q": [Q, [0, 0, 0, "a", 0, 0]]}, "q[1][3]", "must be a valid number"),
        (
            {"q": {"shoulder_pan_joint": "x"}},
            "q.shoulder_pan_joint",
            "must be a number or an array of numbers",
        ),
        (
            {"q": [{"elbow_joint": {}}]},
            "q[0].elbow_joint",
            "must be a number or an array of numbers",
        ),
        ({"q": Q, "jointnames": True}, "jointnames", "is not a field of this request"),
    ],
)
def test_one_entry_per_mistake_in_a_union_typed_field(api, body, loc, msg):
    problem = assert_problem(api.post("/v1/robots/ur5/gravity", json=body), 422, "validation_error")
    assert len(problem["errors"]) == 1, problem["errors"]
    assert problem["errors"][0]["loc"] == loc
    assert problem["errors"][0]["msg"].startswith(msg), problem["errors"][0]["msg"]
    assert problem["detail"] == f"{loc}: {problem['errors'][0]['msg']}"
    assert not any(word in problem["detail"] for word in INTERNAL)


@pytest.mark.parametrize(
    ("wrench", "loc"),
    [
        ([1, 2], "external_forces[0].wrench"),  # one wrench, too short
        ([[1, 2, 3, 4, 5, 6], [1]], "external_forces[0].wrench[1]"),  # one per state, one short
    ],
)
def test_a_wrench_of_the_wrong_size_is_one_mistake(api, wrench, loc):
    body = {
        "q": Q,
        "v": [0] * 6,
        "a": [0] * 6,
        "external_forces": [{"frame": "tool0", "wrench": wrench}],
    }
    problem = assert_problem(
        api.post("/v1/robots/ur5/inverse-dynamics", json=body), 422, "validation_error"
    )
    assert [e["loc"] for e in problem["errors"]] == [loc]
    assert "at least 6" in problem["errors"][0]["msg"]


def test_several_mistakes_are_several_entries(api):
    """One entry per wrong field; an array reports its first wrong item only (validation
    stops there: a body's cost of errors is bounded, whatever its size)."""
    body = {"q": [Q, [0, "a", 0, 0, 0, "b"]], "v": "fast"}
    problem = assert_problem(
        api.post("/v1/robots/ur5/inverse-dynamics", json=body), 422, "validation_error"
    )
    assert sorted(e["loc"] for e in problem["errors"]) == ["a", "q[1][1]", "v"]
    assert problem["detail"].endswith("(and 2 more)")


def test_did_you_mean():
    assert (
        did_you_mean("tool", ["tool0", "base_link", "wrist_3_link"]) == " (did you mean 'tool0'?)"
    )
    assert did_you_mean("gripper", ["tool0", "base_link"]) == ""
    assert did_you_mean("ur6", ["ur5", "ur10", "panda"]).startswith(" (did you mean 'ur5'")
    assert did_you_mean("x" * 65, ["x" * 65]) == ""
    # case differences first (difflib alone finds 'UR5' and 'ur5' too far apart)
    assert did_you_mean("UR5", ["ur3", "ur5", "panda"]) == " (did you mean 'ur5' or 'ur3'?)"
    assert did_you_mean("Tool0", ["tool0", "TOOL0"], most=1) == " (did you mean 'tool0'?)"


def test_an_unknown_robot_in_another_case_is_named(api):
    problem = assert_problem(api.get("/v1/robots/UR5"), 404, "robot_not_found")
    assert "no robot has id 'UR5' (did you mean 'ur5'" in problem["detail"]


@pytest.mark.parametrize(
    ("method", "path", "meant"),
    [
        ("post", "/v1/robots/ur5/mas-matrix", "/v1/robots/ur5/mass-matrix"),
        ("post", "/v1/robots/ur5/Inverse-Dynamics", "/v1/robots/ur5/inverse-dynamics"),
        ("get", "/v1/robot/ur5", "/v1/robots/ur5"),
        ("get", "/v1/robots/panda/inertia", "/v1/robots/panda/inertias"),
    ],
)
def test_a_mistyped_route_gets_close_routes(api, method, path, meant):
    """The route's template filled with the request's own segments (the robot id kept)."""
    problem = assert_problem(getattr(api, method)(path), 404, "not_found")
    assert problem["detail"].startswith(f"no such route (did you mean '{meant}'")


def test_a_route_far_from_every_route_gets_no_suggestion(api):
    for path in ("/nothing/at/all", "/v1/robots/ur5/" + "x" * 300):
        problem = assert_problem(api.get(path), 404, "not_found")
        assert problem["detail"] == "no such route; see /openapi.json or /docs for the API"


def test_an_unknown_frame_gets_close_matches(api):
    problem = assert_problem(
        api.post("/v1/robots/ur5/jacobian", json={"q": Q, "frame": "tool"}), 422, "unknown_frame"
    )
    assert "has no frame 'tool' (did you mean 'tool0'?)" in problem["detail"]
    assert "`frames` of GET /v1/robots/ur5" in problem["detail"]


def test_an_unknown_robot_gets_close_matches(api):
    problem = assert_problem(api.get("/v1/robots/pandaa"), 404, "robot_not_found")
    assert problem["detail"].startswith("no robot has id 'pandaa' (did you mean 'panda'")
    assert "GET /v1/robots lists the valid ids" in problem["detail"]


def test_an_unknown_joint_name_gets_close_matches(api):
    q = {
        "shoulder_pan_joint": 0,
        "shoulder_lift_joint": -1,
        "elbow": 1,
        "wrist_1_joint": 0,
        "wrist_2_joint": 0,
        "wrist_3_joint": 0,
    }
    problem = assert_problem(
        api.post("/v1/robots/ur5/gravity", json={"q": q}), 422, "dimension_mismatch"
    )
    assert "elbow (did you mean 'elbow_joint'?)" in problem["detail"]
    assert problem["missing"] == ["elbow_joint"] and problem["unknown"] == ["elbow"]


def test_an_unknown_locked_joint_gets_close_matches(api):
    problem = assert_problem(
        api.post("/v1/robots/ur5/reduce", json={"locked_joints": {"elbow_jiont": 0.5}}),
        422,
        "validation_error",
    )
    assert "'elbow_jiont' (did you mean 'elbow_joint'?)" in problem["detail"]


@pytest.mark.parametrize(
    ("path", "body", "loc", "meant"),
    [
        ("ur5/gravity", {"q": Q, "jointnames": True}, "jointnames", "joint_names"),
        (
            "ur5/inverse-dynamics",
            {
                "q": Q,
                "v": Q,
                "a": Q,
                "external_forces": [
                    {"frame": "tool0", "wrench": [0] * 6, "refrence_frame": "local"}
                ],
            },
            "external_forces[0].refrence_frame",
            "reference_frame",
        ),
        ("", {"urdf": "<robot/>", "rootjoint": "fixed"}, "rootjoint", "root_joint"),
    ],
)
def test_an_unknown_member_gets_close_matches(api, path, body, loc, meant):
    problem = assert_problem(
        api.post(f"/v1/robots/{path}".rstrip("/"), json=body), 422, "validation_error"
    )
    assert {
        "loc": loc,
        "msg": f"is not a field of this request (did you mean '{meant}'?)",
    } in problem["errors"]


@pytest.mark.parametrize(
    ("path", "body", "msg"),
    [
        (
            "retime",
            {"waypoints": [[0.0] * 6, [0.5] + [0.0] * 5], "acceleration": 1.0},
            'is not a field of this request (it is a member of `limits`: {"limits": {...}})',
        ),
        (
            "retime",
            {"waypoints": [[0.0] * 6, [0.5] + [0.0] * 5], "velocity_scale": 0.5},
            'is not a field of this request (it is a member of `limits`: {"limits": {...}})',
        ),
        (
            "gravity",
            {"q": [0.0] * 6, "mass": 3.0},
            'is not a field of this request (it is a member of `payloads`: {"payloads": [{...}]})',
        ),
    ],
)
def test_a_member_sent_one_level_too_high_is_pointed_to_its_object(api, path, body, msg):
    problem = assert_problem(api.post(f"/v1/robots/ur5/{path}", json=body), 422, "validation_error")
    (wrong,) = set(body) - {"waypoints", "q"}
    assert {"loc": wrong, "msg": msg} in problem["errors"]
