"""The trajectory routes over HTTP: answers equal the in-process computation, and every bad
input is a 422 (413 over the answer budget) with the contract's code naming the field, never
a 5xx."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from service.dynamics.trajectories import check_trajectory, retime
from service.main import create_app
from service.registry import Registry
from service.settings import Settings

CATALOG = "ur5,solo12,panda"


@pytest.fixture(scope="module")
def setup(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[TestClient, Registry]]:
    data: Path = tmp_path_factory.mktemp("trajectories-http")
    settings = Settings(data_dir=data, catalog=CATALOG, max_batch=5000)
    registry = Registry(data, settings.catalog_names())
    registry.load()
    with TestClient(
        create_app(settings, registry=registry), raise_server_exceptions=False
    ) as client:
        yield client, registry


@pytest.fixture(scope="module")
def api(setup) -> TestClient:
    return setup[0]


def _motion(n: int = 31) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 1.5, n)
    return t, np.outer(np.sin(2.0 * t), [0.4, -0.9, 1.1, 0.3, -0.5, 0.8])


WAYPOINTS = np.random.default_rng(0).uniform(-2.0, 2.0, (3, 6))


def test_check_answer_equals_the_in_process_check(api, setup) -> None:
    robot = setup[1].get("ur5")
    t, q = _motion()
    body = {"t": t.tolist(), "q": q.tolist(), "velocity_scale": 0.3, "samples_per_interval": 8}
    r = api.post("/v1/robots/ur5/trajectory-check", json=body)
    assert r.status_code == 200, r.text
    answer = r.json()
    expected = check_trajectory(robot, t, q, velocity_scale=0.3, samples_per_interval=8)
    np.testing.assert_allclose(answer["tau"], expected.tau, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(answer["v"], expected.v, rtol=1e-12, atol=1e-12)
    assert answer["feasible"] is False and answer["violations"] == expected.violations
    assert answer["joints"] == expected.joints and answer["work"] == expected.work
    named = api.post("/v1/robots/ur5/trajectory-check", json={**body, "joint_names": True})
    assert named.json()["tau"][0]["elbow_joint"] == answer["tau"][0][2]


def test_check_with_v_and_a_on_a_free_flyer(api, setup) -> None:
    robot = setup[1].get("solo12")
    q0 = robot.info()["default_configuration"]
    t = [0.0, 0.5, 1.0]
    zeros = np.zeros((3, robot.nv)).tolist()
    r = api.post(
        "/v1/robots/solo12/trajectory-check", json={"t": t, "q": [q0] * 3, "v": zeros, "a": zeros}
    )
    assert r.status_code == 200, r.text
    expected = check_trajectory(robot, t, [q0] * 3, zeros, zeros)
    np.testing.assert_allclose(r.json()["tau"], expected.tau, rtol=1e-12, atol=1e-12)
    without = api.post("/v1/robots/solo12/trajectory-check", json={"t": t, "q": [q0] * 3})
    assert without.status_code == 422 and "v and a are required" in without.json()["detail"]


def test_retime_answer_equals_the_in_process_retime(api, setup) -> None:
    robot = setup[1].get("ur5")
    body = {
        "waypoints": WAYPOINTS.tolist(),
        "limits": {"effort_scale": 0.8, "acceleration": [4.0] * 6},
        "sample_dt": 0.02,
    }
    r = api.post("/v1/robots/ur5/retime", json=body)
    assert r.status_code == 200, r.text
    answer = r.json()
    expected = retime(robot, WAYPOINTS, effort_scale=0.8, acceleration=[4.0] * 6, sample_dt=0.02)
    assert answer["duration"] == expected.duration
    for key in ("t", "q", "v", "a", "tau"):
        np.testing.assert_array_equal(answer[key], getattr(expected, key))
    assert answer["check"]["feasible"] and answer["check"]["violations"] == []
    assert len(answer["check"]["tau"]) == len(answer["t"])


def test_check_with_the_limits_object_acceleration_and_boundary(api, setup) -> None:
    """The limits object (scales and acceleration limits with null entries, as JSON nulls)
    and the boundary give the in-process check's answer; the top-level scales and the limits
    object at once, an unknown boundary, a wrong count of acceleration limits are 422s
    naming them."""
    robot = setup[1].get("ur5")
    t, q = _motion()
    acceleration = [3.0, None, 5.0, None, None, 2.0]
    limits = {"velocity_scale": 0.6, "effort_scale": 0.9, "acceleration": acceleration}
    body = {"t": t.tolist(), "q": q.tolist(), "limits": limits, "boundary": "clamped"}
    r = api.post("/v1/robots/ur5/trajectory-check", json=body)
    assert r.status_code == 200, r.text
    answer = r.json()
    expected = check_trajectory(
        robot,
        t,
        q,
        velocity_scale=0.6,
        effort_scale=0.9,
        acceleration=acceleration,
        boundary="clamped",
    )
    np.testing.assert_allclose(answer["tau"], expected.tau, rtol=1e-12, atol=1e-12)
    assert answer["joints"] == expected.joints and answer["violations"] == expected.violations
    assert [j["acceleration_limit"] for j in answer["joints"]] == acceleration
    assert {x["kind"] for x in answer["violations"]} >= {"acceleration"}
    top = {"t": t.tolist(), "q": q.tolist(), "velocity_scale": 0.6, "effort_scale": 0.9}
    same = api.post("/v1/robots/ur5/trajectory-check", json={**top, "boundary": "clamped"})
    assert (
        same.json()["tau"]
        == check_trajectory(
            robot, t, q, velocity_scale=0.6, effort_scale=0.9, boundary="clamped"
        ).tau.tolist()
    )
    for bad, words in (
        ({**top, "limits": {"velocity_scale": 0.5}}, "at top level and limits"),
        ({**body, "boundary": "periodic"}, "boundary"),
        ({**body, "limits": {"acceleration": [1.0] * 5}}, "limits.acceleration has 5 entries"),
        ({**body, "limits": {"acceleration": [1.0, 0.0] * 3}}, "limits.acceleration"),
    ):
        refused = api.post("/v1/robots/ur5/trajectory-check", json=bad)
        assert refused.status_code == 422, refused.text
        assert words in refused.json()["detail"]


def test_retime_with_fingers_on_their_limits_and_null_acceleration_limits(api) -> None:
    """The Panda's arm joints keyed by name, its fingers filled from the default pose (one of
    them at its lower limit 0), acceleration limits only on the arm: timed, within every
    limit (its own check)."""
    arm = [f"panda_joint{i}" for i in range(1, 8)]
    waypoints = [
        dict(zip(arm, [0.0, -0.5, 0.0, -2.0, 0.0, 1.5, 0.7], strict=True)),
        dict(zip(arm, [0.5, -0.3, 0.2, -1.8, 0.1, 1.7, 0.9], strict=True)),
    ]
    body = {
        "waypoints": waypoints,
        "fill": "default",
        "limits": {"acceleration": [5.0] * 7 + [None, None]},
    }
    r = api.post("/v1/robots/panda/retime", json=body)
    assert r.status_code == 200, r.text
    check = r.json()["check"]
    assert check["feasible"]
    fingers = {j["name"]: j for j in check["joints"] if "finger" in j["name"]}
    assert (
        fingers["panda_finger_joint2"]["min_position"]
        == 0.0
        == fingers["panda_finger_joint2"]["lower"]
    )
    assert fingers["panda_finger_joint1"]["acceleration_limit"] is None
    assert max(j["acceleration_ratio"] or 0 for j in check["joints"]) <= 1 + 1e-6


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"t": [0.0, 1.0, 1.0]}, "t must be strictly increasing"),
        ({"t": [0.0, 1.0, "NaN"]}, "t"),
        ({"t": [0.0, 1.0]}, "q has 3 samples; t has 2"),
        ({"t": [0.0], "q": [[0.0] * 6]}, "t has 1 sample"),
        ({"q": [[0.0] * 5] * 3}, "nq = 6"),
        ({"v": [[0.0] * 6] * 2}, "batch sizes differ"),
        ({"effort_scale": 0}, "effort_scale"),
        ({"velocity_scale": -1.0}, "velocity_scale"),
        ({"samples_per_interval": 0}, "samples_per_interval"),
        ({"samples_per_interval": 65}, "samples_per_interval"),
        (
            {"t": list(range(5001)), "q": [[0.0] * 6] * 5001},
            "q has 5001 rows (states); the limit is 5000",
        ),
    ],
)
def test_bad_check_input_is_a_422_naming_the_field(api, body: dict, field: str) -> None:
    request = {"t": [0.0, 1.0, 2.0], "q": [[0.0] * 6] * 3, **body}
    r = api.post("/v1/robots/ur5/trajectory-check", json=request)
    assert r.status_code == 422, r.text
    problem = r.json()
    assert problem["code"] in ("validation_error", "dimension_mismatch")
    assert field in problem["detail"] or any(
        field in str(e.get("loc")) for e in problem.get("errors", [])
    ), problem


@pytest.mark.parametrize(
    ("body", "code", "field"),
    [
        ({"waypoints": [[0.0] * 6]}, "validation_error", "waypoints has 1 row"),
        ({"waypoints": [[0.0] * 5, [1.0] * 5]}, "dimension_mismatch", "nq = 6"),
        (
            '{"waypoints": [[0, 0, 0, 0, 0, 0], [1e400, 0, 0, 0, 0, 0]]}',
            "validation_error",
            "waypoints",
        ),
        ({"limits": {"velocity_scale": 0}}, "validation_error", "velocity_scale"),
        ({"limits": {"effort_scale": -2}}, "validation_error", "effort_scale"),
        (
            {"limits": {"acceleration": [1.0, 1.0, 0.0, 1.0, 1.0, 1.0]}},
            "validation_error",
            "limits.acceleration",
        ),
        ({"limits": {"acceleration": [1.0] * 5}}, "dimension_mismatch", "limits.acceleration"),
        ({"sample_dt": 0}, "validation_error", "sample_dt"),
        ({"sample_dt": 1e-6}, "validation_error", "sample_dt"),
        ({"limits": {"effort_scale": 0.3}}, "infeasible_path", "shoulder_lift_joint"),
    ],
)
def test_bad_retime_input_is_a_422_with_its_code(
    api, body: dict | str, code: str, field: str
) -> None:
    if isinstance(body, str):  # JSON text Python's encoder would not write (1e400 → inf)
        r = api.post(
            "/v1/robots/ur5/retime", content=body, headers={"content-type": "application/json"}
        )
    else:
        r = api.post("/v1/robots/ur5/retime", json={"waypoints": WAYPOINTS.tolist(), **body})
    assert r.status_code == 422, r.text
    problem = r.json()
    assert problem["code"] == code
    assert field in problem["detail"] or any(
        field in str(e.get("loc")) for e in problem.get("errors", [])
    ), problem


HELD = [0.0, -1.57, 1.57, 0.0, 0.0, 0.0]  # gravity needs 0.36 of the UR5's torque limits


def _shifted(step: float) -> list[float]:
    return [x + step for x in HELD]


def test_paths_gravity_holds_are_timed_whatever_their_scale(api) -> None:
    """A 1000-waypoint ±0.01 rad zig-zag, two waypoints 1e-10 rad apart, A → A + 1e-11 → B
    (merged: A → B), each answered within its limits, not called infeasible."""
    zigzag = [[HELD[0] + (0.01 if i % 2 else -0.01), *HELD[1:]] for i in range(1000)]
    tiny = [HELD, _shifted(1e-10)]
    for waypoints in (zigzag, tiny):
        r = api.post("/v1/robots/ur5/retime", json={"waypoints": waypoints})
        assert r.status_code == 200, r.text
        assert r.json()["check"]["feasible"] and r.json()["duration"] > 0
    plain = api.post("/v1/robots/ur5/retime", json={"waypoints": [HELD, _shifted(0.5)]})
    merged = api.post(
        "/v1/robots/ur5/retime", json={"waypoints": [HELD, _shifted(1e-11), _shifted(0.5)]}
    )
    assert merged.status_code == 200, merged.text
    assert merged.json()["duration"] == plain.json()["duration"]


@pytest.mark.parametrize(
    ("body", "code", "words"),
    [
        ({"limits": {"velocity_scale": 1e-10}}, "validation_error", "sample_dt: the motion lasts"),
        ({"limits": {"acceleration": [1e-19] * 6}}, "validation_error", "the motion lasts"),
        ({"limits": {"acceleration": [5e-324] * 6}}, "validation_error", "limits.acceleration"),
        ({"limits": {"velocity_scale": 1e-300}}, "validation_error", "limits.velocity_scale"),
        ({"sample_dt": 5e-324}, "validation_error", "sample_dt: the motion lasts"),
        (
            {"waypoints": [[-1e154] * 6, [1e154] * 6]},
            "infeasible_path",
            "leaves its position limits",
        ),
        (
            {"waypoints": [[-1e308] * 6, [1e308] * 6]},
            "validation_error",
            "waypoints 0 and 1 are too far apart",
        ),
    ],
)
def test_retime_limits_and_paths_beyond_float64_are_422s(api, body, code, words) -> None:
    """Motions too long to sample, limits whose path quantities overflow, waypoints whose
    distance overflows: each a 422 naming its input."""
    r = api.post("/v1/robots/ur5/retime", json={"waypoints": [HELD, _shifted(0.5)], **body})
    assert r.status_code == 422, r.text
    assert r.json()["code"] == code and words in r.json()["detail"], r.json()


@pytest.mark.parametrize(
    ("body", "words"),
    [
        ({"t": [0.0, 5e-324], "q": [HELD, _shifted(0.1)]}, "t and q: between samples 0 and 1"),
        ({"t": [0.0, 1e-10], "q": [HELD, _shifted(1e300)]}, "t and q: between samples 0 and 1"),
        ({"effort_scale": 5e-324}, "effort_scale is too small"),
    ],
)
def test_check_inputs_beyond_float64_are_422s(api, body, words) -> None:
    r = api.post(
        "/v1/robots/ur5/trajectory-check",
        json={"t": [0.0, 1.0, 2.0], "q": [HELD, _shifted(0.1), HELD], **body},
    )
    assert r.status_code == 422, r.text
    assert r.json()["code"] == "validation_error" and words in r.json()["detail"], r.json()


def test_infeasible_path_names_joint_waypoint_and_fraction(api) -> None:
    r = api.post(
        "/v1/robots/ur5/retime",
        json={"waypoints": WAYPOINTS.tolist(), "limits": {"effort_scale": 0.3}},
    )
    problem = r.json()
    assert problem["joint"] == "shoulder_lift_joint" and problem["waypoint"] == 0
    assert 0 < problem["path_fraction"] < 1


def test_unsupported_model_is_a_422(api) -> None:
    r = api.post("/v1/robots/solo12/retime", json={"waypoints": [[0.0] * 19] * 2})
    assert r.status_code == 422 and r.json()["code"] == "unsupported_model"


def test_retime_over_the_answer_budget_is_a_413(tmp_path: Path) -> None:
    settings = Settings(data_dir=tmp_path, catalog="ur5", max_answer_bytes=50_000)
    registry = Registry(tmp_path, ["ur5"])
    registry.load()
    with TestClient(
        create_app(settings, registry=registry), raise_server_exceptions=False
    ) as client:
        r = client.post("/v1/robots/ur5/retime", json={"waypoints": WAYPOINTS.tolist()})
        assert r.status_code == 413 and r.json()["code"] == "payload_too_large", r.text
        assert "sample_dt" in r.json()["detail"]
        coarse = client.post(
            "/v1/robots/ur5/retime", json={"waypoints": WAYPOINTS.tolist(), "sample_dt": 0.2}
        )
        assert coarse.status_code == 200, coarse.text


def test_both_routes_speak_the_binary_form(api) -> None:
    """A safetensors body and answer (the check's arrays as tensors; retime's nested check as
    JSON in the metadata), the same numbers as JSON."""
    from robodyn import binary

    headers = {"content-type": binary.MEDIA_TYPE, "accept": binary.MEDIA_TYPE}
    t, q = _motion()
    for route, arrays, fields in (
        ("retime", {"waypoints": WAYPOINTS}, {}),
        ("trajectory-check", {"q": q}, {"t": t.tolist()}),
    ):
        r = api.post(
            f"/v1/robots/ur5/{route}", content=binary.encode(arrays, fields), headers=headers
        )
        assert r.status_code == 200, r.text
        answer = binary.decode(r.content)
        as_json = api.post(
            f"/v1/robots/ur5/{route}", json={**{k: a.tolist() for k, a in arrays.items()}, **fields}
        ).json()
        np.testing.assert_array_equal(answer["tau"], as_json["tau"])
        check = answer["check"] if route == "retime" else answer
        assert check["feasible"] == (as_json["check"] if route == "retime" else as_json)["feasible"]


def test_a_long_checks_times_may_come_as_a_tensor(tmp_path: Path) -> None:
    """60,000 irregular sample times do not fit in a safetensors header (1 MiB): `t` may be a
    1-D tensor like q; the answer is the one of the JSON form. Twice given, or 2-D: a 422."""
    from robodyn import binary

    settings = Settings(data_dir=tmp_path, catalog="ur5")  # the default batch limit
    registry = Registry(tmp_path, settings.catalog_names())
    registry.load()
    api = TestClient(create_app(settings, registry=registry), raise_server_exceptions=False)

    headers = {"content-type": binary.MEDIA_TYPE}
    n = 60_000
    t = np.cumsum(np.random.default_rng(3).uniform(0.9e-3, 1.1e-3, n))
    q = np.stack([0.4 * np.sin((j + 1) * 0.3 * t) for j in range(6)], axis=1)
    in_header = api.post(
        "/v1/robots/ur5/trajectory-check",
        content=binary.encode({"q": q}, {"t": t.tolist()}),
        headers=headers,
    )
    assert in_header.status_code == 422 and "header" in in_header.json()["detail"]
    as_tensor = api.post(
        "/v1/robots/ur5/trajectory-check",
        content=binary.encode({"t": t, "q": q}, {"samples_per_interval": 2}),
        headers=headers,
    )
    assert as_tensor.status_code == 200, as_tensor.text[:300]
    as_json = api.post(
        "/v1/robots/ur5/trajectory-check",
        json={"t": t.tolist(), "q": q.tolist(), "samples_per_interval": 2},
    )
    assert as_tensor.json() == as_json.json()
    twice = api.post(
        "/v1/robots/ur5/trajectory-check",
        content=binary.encode({"t": t[:10], "q": q[:10]}, {"t": t[:10].tolist()}),
        headers=headers,
    )
    assert twice.status_code == 422 and "both" in twice.json()["detail"]
    flat = api.post(
        "/v1/robots/ur5/trajectory-check",
        content=binary.encode({"t": t[:10].reshape(5, 2), "q": q[:10]}),
        headers=headers,
    )
    assert flat.status_code == 422 and "tensor t has shape [5, 2]" in flat.json()["detail"]
    nan = t[:10].copy()
    nan[3] = np.nan
    refused = api.post(
        "/v1/robots/ur5/trajectory-check",
        content=binary.encode({"t": nan, "q": q[:10]}),
        headers=headers,
    )
    assert refused.status_code == 422 and refused.json()["code"] == "validation_error"


def test_payloads_apply_to_both_routes(api, setup) -> None:
    """With a 5 kg payload at the flange the routes answer for the robot carrying it: equal
    to the in-process computation on that robot, and a heavier load than without it."""
    from service.dynamics.payloads import robot_with_payloads

    payloads = [{"frame": "tool0", "mass": 5.0}]
    carrying = robot_with_payloads(setup[1].get("ur5"), payloads)
    t, q = _motion()
    r = api.post(
        "/v1/robots/ur5/trajectory-check",
        json={"t": t.tolist(), "q": q.tolist(), "payloads": payloads},
    )
    assert r.status_code == 200, r.text
    expected = check_trajectory(carrying, t, q)
    np.testing.assert_allclose(r.json()["tau"], expected.tau, rtol=1e-12, atol=1e-12)
    bare = api.post("/v1/robots/ur5/trajectory-check", json={"t": t.tolist(), "q": q.tolist()})
    assert r.json()["joints"][1]["peak_effort"] > bare.json()["joints"][1]["peak_effort"]
    timed = api.post(
        "/v1/robots/ur5/retime", json={"waypoints": WAYPOINTS.tolist(), "payloads": payloads}
    )
    assert timed.status_code == 200, timed.text
    assert timed.json()["duration"] == retime(carrying, WAYPOINTS).duration
    assert timed.json()["duration"] > retime(setup[1].get("ur5"), WAYPOINTS).duration


def test_a_long_motion_is_checked_whole_and_can_be_stopped(tmp_path: Path) -> None:
    """More samples than a stoppable batch's chunk: the samples are one motion, so the check
    takes them whole (it asks `should_stop` itself), equal to the in-process check; and a
    true `should_stop` stops both quantities."""
    from service import dynamics
    from service.errors import ComputationStopped
    from service.states import States

    settings = Settings(data_dir=tmp_path, catalog="ur5")
    registry = Registry(tmp_path, ["ur5"])
    registry.load()
    robot = registry.get("ur5")
    n = 9_000  # over 50,000 / nv states: run() would cut a batch here
    t = np.linspace(0.0, 30.0, n)
    q = np.outer(np.sin(t), [0.4, -0.9, 1.1, 0.3, -0.5, 0.8])
    with TestClient(
        create_app(settings, registry=registry), raise_server_exceptions=False
    ) as client:
        r = client.post(
            "/v1/robots/ur5/trajectory-check",
            json={"t": t.tolist(), "q": q.tolist(), "samples_per_interval": 2},
        )
    assert r.status_code == 200, r.text
    expected = check_trajectory(robot, t, q, samples_per_interval=2)
    np.testing.assert_allclose(r.json()["tau"], expected.tau, rtol=1e-12, atol=1e-12)
    for name, arrays, options in (
        ("trajectory-check", {"q": q}, {"t": t}),
        ("retime", {"waypoints": WAYPOINTS}, {}),
    ):
        quantity = dynamics.QUANTITIES[name]
        assert quantity.stoppable
        with pytest.raises(ComputationStopped, match="stopped at"):
            dynamics.run(robot, quantity, States(arrays, True), options, lambda: True)


def test_friction_of_an_identified_robot_adds_to_the_checked_torques(api, setup) -> None:
    """`"friction": true` on a robot stored by identification: τ at the samples is the
    frictionless τ of the same robot plus offset + coulomb ∘ sign(v) + viscous ∘ v, and the
    work follows; on a robot without identified friction it is a 422 naming the reason."""
    from service.dynamics.identification import inertial_parameters
    from service.registry.variants import Fitted

    registry = setup[1]
    model = registry.get("ur5").model
    friction = tuple(
        (str(model.names[j]), 0.5 + 0.1 * j, 0.2 * j, -0.05 * j) for j in range(1, model.njoints)
    )
    fitted = Fitted(tuple(float(x) for x in inertial_parameters(model)), friction)
    robot, _ = registry.variant("ur5", fitted=fitted, name="ur5 with friction")
    t, q = _motion()
    body = {"t": t.tolist(), "q": q.tolist()}
    path = f"/v1/robots/{robot.id}/trajectory-check"
    plain, rubbing = (api.post(path, json={**body, "friction": on}) for on in (False, True))
    assert plain.status_code == 200 and rubbing.status_code == 200, rubbing.text
    v = np.array(plain.json()["v"])
    coulomb = np.array([f[1] for f in friction])
    viscous = np.array([f[2] for f in friction])
    offset = np.array([f[3] for f in friction])
    expected = np.array(plain.json()["tau"]) + offset + coulomb * np.sign(v) + viscous * v
    np.testing.assert_allclose(rubbing.json()["tau"], expected, rtol=1e-12, atol=1e-12)
    assert rubbing.json()["work"]["positive"] > plain.json()["work"]["positive"]
    refused = api.post("/v1/robots/ur5/trajectory-check", json={**body, "friction": True})
    assert refused.status_code == 422 and "no friction model" in refused.json()["detail"]
