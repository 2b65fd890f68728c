"""Payloads over HTTP: every computing route answers for the robot carrying them, equal to the
in-process computation (JSON, binary form, stream, joint names); the payload capacity route
equals the physics; a standing robot carries its payload; every bad payload is a 422 with the
contract's code, never a 5xx."""

from __future__ import annotations

import numpy as np
import orjson
import pinocchio as pin
import pytest

from service import dynamics
from service.api.encoding.binary import BINARY_MEDIA_TYPE
from service.dynamics.payload_capacity import capacity
from service.dynamics.payloads import robot_with_payloads
from service.states import prepare
from tests.helpers import random_state
from tests.service.api.encoding.test_binary import decode_answer, encode_request
from tests.service.dynamics.test_payloads import BAD

G = 9.81
PAYLOADS = {  # robot -> payloads it holds
    "ur5": [
        {
            "frame": "tool0",
            "mass": 3.0,
            "center_of_mass": [0.0, 0.01, 0.05],
            "inertia": np.diag([0.01, 0.012, 0.008]).tolist(),
        }
    ],
    "solo12": [
        {"frame": "base_link", "mass": 1.2, "center_of_mass": [0.03, 0.0, 0.06]},
        {"frame": "FL_LOWER_LEG", "mass": 0.2},
    ],
}


def _frame(robot) -> str:
    return "tool0" if robot.id == "ur5" else "FL_FOOT"


def _options(name: str, robot) -> dict:
    """The options a quantity needs (or shows) besides its joint-space inputs."""
    frame = _frame(robot)
    feet = [dict(c) for c in robot.contact_frames] or [{"frame": frame, "type": "point"}]
    return {
        "jacobian": {"frame": frame},
        "operational-space": {"frame": frame},
        "simulate": {"dt": 0.001, "steps": 4},
        "contact-dynamics": {"contacts": feet},
        "contact-inverse-dynamics": {"contacts": feet},
        "impulse-dynamics": {"contacts": feet},
        "payload-capacity": {"frame": frame},
        "trajectory-check": {"t": [0.0, 0.5]},
    }.get(name, {})


def _inputs(robot, quantity, n: int, seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    states = [random_state(robot.model, rng) for _ in range(n)]
    q = np.array([s[0] for s in states])
    if robot.root_joint == "free-flyer":  # standing where contacts can hold
        q[:] = robot.default_configuration
    out = {"q": q}
    for name in (*quantity.inputs, *quantity.optional):
        if name != "q":
            out[name] = 0.1 * rng.normal(size=(n, robot.nv))
    if "contacts" in _options(quantity.name, robot):
        out["v"] = np.zeros((n, robot.nv))
    return out


def _in_process(robot, quantity, arrays, options, payloads) -> dict:
    carried = robot_with_payloads(robot, payloads)
    states = prepare(carried, arrays, 100)
    return dynamics.run(carried, quantity, states, dict(options))


def _same(got, want) -> None:
    if isinstance(want, dict):
        assert set(got) == set(want)
        for key in want:
            _same(got[key], want[key])
    elif isinstance(want, list) and want and isinstance(want[0], dict):
        assert len(got) == len(want)
        for g, w in zip(got, want, strict=True):
            _same(g, w)
    elif isinstance(want, str | type(None)) or (
        isinstance(want, list) and want and isinstance(want[0], str | type(None))
    ):
        assert got == want
    else:
        want = np.asarray(want, dtype=float)
        got = np.asarray([np.nan if x is None else x for x in np.ravel(got)], dtype=float).reshape(
            want.shape
        )
        np.testing.assert_allclose(
            got, np.where(np.isinf(want), np.nan, want), rtol=1e-12, atol=1e-12
        )


# retime takes waypoints of a fixed-base arm, not states: its payloads are tested with it
# (tests/service/dynamics/trajectories/test_http.py)
@pytest.mark.parametrize("robot_id", sorted(PAYLOADS))
@pytest.mark.parametrize("name", sorted(set(dynamics.QUANTITIES) - {"retime"}))
def test_every_computing_route_answers_for_the_robot_carrying_the_payloads(
    api, catalog_registry, robot_id, name
):
    robot = catalog_registry.catalog[robot_id]
    quantity = dynamics.QUANTITIES[name]
    arrays = _inputs(robot, quantity, 2, seed=len(name))
    options = _options(name, robot)
    settings = {s: getattr(api.app.state.settings, s) for s in quantity.settings}
    body = {**{k: v.tolist() for k, v in arrays.items()}, **options, "payloads": PAYLOADS[robot_id]}
    r = api.post(f"/v1/robots/{robot_id}/{name}", json=body)
    assert r.status_code == 200, r.text
    want = _in_process(robot, quantity, arrays, {**options, **settings}, PAYLOADS[robot_id])
    _same(r.json(), want)
    if name in ("mass-matrix", "gravity", "inverse-dynamics", "contact-inverse-dynamics"):
        bare = api.post(
            f"/v1/robots/{robot_id}/{name}", json={k: v for k, v in body.items() if k != "payloads"}
        ).json()
        key = next(iter(want))
        assert not np.allclose(bare[key], r.json()[key])  # the payload changed the answer


def test_binary_form_stream_and_joint_names_carry_payloads(api, catalog_registry):
    robot = catalog_registry.catalog["ur5"]
    arrays = _inputs(robot, dynamics.QUANTITIES["inverse-dynamics"], 80, seed=4)
    payloads = PAYLOADS["ur5"]
    want = api.post(
        "/v1/robots/ur5/inverse-dynamics",
        json={**{k: v.tolist() for k, v in arrays.items()}, "payloads": payloads},
    ).json()["tau"]
    r = api.post(
        "/v1/robots/ur5/inverse-dynamics",
        content=encode_request(arrays, {"payloads": payloads}),
        headers={"content-type": BINARY_MEDIA_TYPE, "accept": BINARY_MEDIA_TYPE},
    )
    assert r.status_code == 200, r.text
    np.testing.assert_array_equal(decode_answer(r.content)["tau"], want)
    one = {k: v[0].tolist() for k, v in arrays.items()}
    with api.websocket_connect("/v1/robots/ur5/stream") as ws:
        ws.send_text(
            orjson.dumps({"quantity": "inverse-dynamics", **one, "payloads": payloads}).decode()
        )
        assert ws.receive_json()["tau"] == want[0]
        ws.send_text(
            orjson.dumps(
                {"quantity": "gravity", "q": one["q"], "payloads": [{"frame": "tool0", "mass": -1}]}
            ).decode()
        )
        problem = ws.receive_json()
        assert problem["code"] == "validation_error" and "payloads[0].mass" in problem["detail"]
    names = [j["name"] for j in api.get("/v1/robots/ur5").json()["joints"]]
    named = api.post(
        "/v1/robots/ur5/inverse-dynamics",
        json={
            **{k: dict(zip(names, v, strict=True)) for k, v in one.items()},
            "payloads": payloads,
            "joint_names": True,
        },
    ).json()["tau"]
    assert [named[n] for n in names] == pytest.approx(want[0], rel=1e-12, abs=1e-12)


def test_payload_capacity_route_equals_the_physics(api, catalog_registry):
    robot = catalog_registry.catalog["ur5"]
    rng = np.random.default_rng(8)
    q, v, a = (
        np.array(x) for x in zip(*[random_state(robot.model, rng) for _ in range(70)], strict=True)
    )
    com, carried = [0.0, 0.0, 0.08], [{"frame": "wrist_3_link", "mass": 0.7}]
    cap = capacity(robot, q, "tool0", center_of_mass=com, v=v, a=a, payloads=carried)
    body = {
        "q": q.tolist(),
        "v": v.tolist(),
        "a": a.tolist(),
        "frame": "tool0",
        "center_of_mass": com,
        "payloads": carried,
    }
    got = api.post("/v1/robots/ur5/payload-capacity", json=body).json()
    _same(got, cap.answer(batched=True))
    assert got["minimum"]["state"] == int(np.argmin(cap.mass))
    binary = api.post(
        "/v1/robots/ur5/payload-capacity",
        content=encode_request(
            {"q": q, "v": v, "a": a}, {k: body[k] for k in ("frame", "center_of_mass", "payloads")}
        ),
        headers={"content-type": BINARY_MEDIA_TYPE, "accept": BINARY_MEDIA_TYPE},
    )
    assert binary.status_code == 200, binary.text
    np.testing.assert_array_equal(decode_answer(binary.content)["mass"], cap.mass)
    # one state, limits keyed by joint name
    names = [j["name"] for j in api.get("/v1/robots/ur5").json()["joints"]]
    limits = dict(zip(names, [150.0, 150.0, 150.0, 28.0, 28.0, 0.0], strict=True))
    one = api.post(
        "/v1/robots/ur5/payload-capacity",
        json={"q": q[0].tolist(), "frame": "tool0", "effort_limits": limits},
    ).json()
    want = capacity(robot, q[:1], "tool0", effort_limits=np.array(list(limits.values())))
    _same(one, want.answer(batched=False))
    assert isinstance(one["mass"], float) and "minimum" not in one


def test_a_point_no_joint_feels_never_limits_over_http(api, catalog_registry):
    """A mass at the UR5's shoulder-lift origin, holding still: on the lift axis, its weight
    along the pan axis. No joint feels it in any state: every capacity is null (the contract's
    "never limits"), and τ is the robot's own gravity torque."""
    robot = catalog_registry.catalog["ur5"]
    rng = np.random.default_rng(77)
    q = np.array([random_state(robot.model, rng)[0] for _ in range(200)])
    answer = api.post(
        "/v1/robots/ur5/payload-capacity",
        json={"q": q.tolist(), "frame": "shoulder_lift_joint"},
    )
    assert answer.status_code == 200, answer.text
    got = answer.json()
    assert got["mass"] == [None] * 200 and got["limiting_joint"] == [None] * 200
    assert got["mass_per_joint"] == [[None] * 6] * 200
    assert got["mass_range"] == [[0.0, None]] * 200  # every mass ≥ 0, no upper end
    assert got["minimum"] == {
        "mass": None,
        "state": None,
        "limiting_joint": None,
        "mass_range": [0.0, None],
    }
    data = robot.model.createData()
    gravity = [pin.computeGeneralizedGravity(robot.model, data, row) for row in q]
    np.testing.assert_allclose(got["tau"], gravity, rtol=1e-12, atol=1e-12)


def test_a_standing_robot_carries_its_payload(api, catalog_registry):
    """Solo-12 on its four feet with a payload on its back: Σ contact forces = (m + m_p) g."""
    robot = catalog_registry.catalog["solo12"]
    zero = [0.0] * robot.nv
    body = {
        "q": robot.default_configuration.tolist(),
        "v": zero,
        "a": zero,
        "contacts": [dict(c) for c in robot.contact_frames],
        "payloads": PAYLOADS["solo12"],
    }
    out = api.post("/v1/robots/solo12/contact-inverse-dynamics", json=body).json()
    forces = np.array(out["contact_forces"]).reshape(-1, 3)
    weight = (robot.total_mass + sum(p["mass"] for p in PAYLOADS["solo12"])) * G
    assert abs(forces[:, 2].sum() - weight) <= 1e-9 * weight
    assert np.abs(forces[:, :2].sum(axis=0)).max() <= 1e-9 * weight


SHAPE_MISTAKES = {  # refused while parsing, as every malformed body
    "mass-text": {"frame": "tool0", "mass": "3"},
    "extra-member": {"frame": "tool0", "mass": 1.0, "colour": "red"},
    "frame-number": {"frame": 3, "mass": 1.0},
    "inertia-flat": {"frame": "tool0", "mass": 1.0, "inertia": [1, 0, 0]},
    "not-an-object": 3.0,
}
ROUTES = {  # route -> a body without payloads
    "gravity": {"q": [0.1] * 6},
    "payload-capacity": {"q": [0.1] * 6, "frame": "tool0"},
    "simulate": {"q": [0.1] * 6, "v": [0.0] * 6, "dt": 0.001, "steps": 2},
    "variants": {},
}


@pytest.mark.parametrize("route", sorted(ROUTES))
def test_every_bad_payload_is_a_422_with_the_contracts_code(api, route):
    cases = [
        (payload, "unknown_frame" if error.__name__ == "UnknownFrame" else "validation_error")
        for payload, error, _ in BAD.values()
    ]
    cases += [(p, "validation_error") for p in SHAPE_MISTAKES.values()]
    cases.append(([{"frame": "tool0", "mass": 1.0}] * 17, "validation_error"))
    for payload, code in cases:
        payloads = (
            payload if isinstance(payload, list) else [{"frame": "tool0", "mass": 1.0}, payload]
        )
        text = orjson.dumps(
            {**ROUTES[route], "payloads": payloads}, option=orjson.OPT_SERIALIZE_NUMPY
        )
        r = api.post(
            f"/v1/robots/ur5/{route}", content=text, headers={"content-type": "application/json"}
        )
        assert r.status_code == 422, (route, payload, r.text)
        assert r.headers["content-type"] == "application/problem+json"
        assert r.json()["code"] == code, (payload, r.json())
