"""Joint-space inputs keyed by joint name (in any order) equal the array form; `"joint_names":
true` keys the joint-space answers by name; missing and unknown names are 422s listing them."""

from __future__ import annotations

import numpy as np
import pytest

from service.api.encoding import binary
from tests.helpers import random_state
from tests.service.api.problems.test_errors import assert_problem

INPUTS = {
    "mass-matrix": "q",
    "gravity": "q",
    "coriolis": "qv",
    "nonlinear-effects": "qv",
    "inverse-dynamics": "qva",
    "forward-dynamics": "qvt",
    "inverse-dynamics-derivatives": "qva",
    "forward-dynamics-derivatives": "qvt",
    "centroidal": "qv",
}
NAMES = {"q": "q", "v": "v", "a": "a", "t": "tau"}
KEYED = {
    "gravity": ["gravity"],
    "coriolis": ["coriolis_forces"],
    "nonlinear-effects": ["nonlinear_effects"],
    "inverse-dynamics": ["tau"],
    "forward-dynamics": ["a"],
}


def keyed(info: dict, vector: np.ndarray, space: str, rng: np.random.Generator) -> dict:
    """`vector` as an object keyed by joint name, in a shuffled order; 1-dof joints as a
    number or a 1-list at random."""
    start, size = ("idx_q", "nq") if space == "q" else ("idx_v", "nv")
    joints = list(info["joints"])
    rng.shuffle(joints)
    out = {}
    for j in joints:
        part = vector[j[start] : j[start] + j[size]].tolist()
        out[j["name"]] = part[0] if len(part) == 1 and rng.random() < 0.5 else part
    return out


def _post(api, robot, path, body):
    r = api.post(f"/v1/robots/{robot}/{path}", json=body)
    assert r.status_code == 200, r.text
    return r.json()


@pytest.mark.parametrize("robot", ["ur5", "double_pendulum_continuous", "solo12", "talos"])
@pytest.mark.parametrize("quantity", list(INPUTS))
def test_name_keyed_input_in_any_order_equals_the_array_form(
    api, catalog_registry, robot, quantity
):
    model, info = catalog_registry.catalog[robot].model, catalog_registry.catalog[robot].info()
    rng = np.random.default_rng(40)
    q, v, a = random_state(model, rng)
    values = {"q": q, "v": v, "a": a, "t": a}
    arrays = {NAMES[c]: values[c].tolist() for c in INPUTS[quantity]}
    by_name = {NAMES[c]: keyed(info, values[c], c, rng) for c in INPUTS[quantity]}
    assert _post(api, robot, quantity, by_name) == _post(api, robot, quantity, arrays)
    mixed = {**arrays, "q": by_name["q"]}  # one input by name, the others as arrays
    assert _post(api, robot, quantity, mixed) == _post(api, robot, quantity, arrays)


def test_a_batch_of_name_keyed_states_equals_the_array_batch(api, catalog_registry):
    model, info = (
        catalog_registry.catalog["solo12"].model,
        catalog_registry.catalog["solo12"].info(),
    )
    rng = np.random.default_rng(41)
    states = [random_state(model, rng) for _ in range(3)]
    arrays = {
        "q": [s[0].tolist() for s in states],
        "v": [s[1].tolist() for s in states],
        "a": [s[2].tolist() for s in states],
    }
    names = {
        "q": [keyed(info, s[0], "q", rng) for s in states],
        "v": [keyed(info, s[1], "v", rng) for s in states],
        "a": [keyed(info, s[2], "a", rng) for s in states],
    }
    assert _post(api, "solo12", "inverse-dynamics", names) == _post(
        api, "solo12", "inverse-dynamics", arrays
    )


@pytest.mark.parametrize("quantity", list(KEYED))
def test_joint_names_true_keys_vector_answers_by_joint(api, catalog_registry, quantity):
    robot = "solo12"
    model, info = catalog_registry.catalog[robot].model, catalog_registry.catalog[robot].info()
    rng = np.random.default_rng(42)
    q, v, a = random_state(model, rng)
    values = {"q": q, "v": v, "a": a, "t": a}
    body = {NAMES[c]: values[c].tolist() for c in INPUTS[quantity]}
    plain = _post(api, robot, quantity, body)
    named = _post(api, robot, quantity, {**body, "joint_names": True})
    assert set(named) == set(plain)
    for key in plain:
        if key not in KEYED[quantity]:
            assert named[key] == plain[key]  # matrices stay arrays
            continue
        assert list(named[key]) == [j["name"] for j in info["joints"]]
        for j in info["joints"]:
            part = plain[key][j["idx_v"] : j["idx_v"] + j["nv"]]
            assert named[key][j["name"]] == (part[0] if j["nv"] == 1 else part)
    # a batch answers a list of objects, one per state
    batch = _post(
        api, robot, quantity, {**{k: [x, x] for k, x in body.items()}, "joint_names": True}
    )
    for key in KEYED[quantity]:
        assert batch[key] == [named[key], named[key]]


def test_joint_names_false_and_matrices(api):
    body = {"q": [0.1] * 6}
    assert _post(api, "ur5", "gravity", {**body, "joint_names": False}) == _post(
        api, "ur5", "gravity", body
    )
    assert _post(api, "ur5", "mass-matrix", {**body, "joint_names": True}) == _post(
        api, "ur5", "mass-matrix", body
    )


def test_simulate_by_name_in_and_out(api, catalog_registry):
    model, info = (
        catalog_registry.catalog["solo12"].model,
        catalog_registry.catalog["solo12"].info(),
    )
    rng = np.random.default_rng(43)
    q, v, tau = random_state(model, rng)
    target = random_state(model, rng)[0]
    kp = rng.uniform(1, 2, model.nv)
    arrays = {
        "q": q.tolist(),
        "v": v.tolist(),
        "dt": 1e-3,
        "steps": 3,
        "controller": {"type": "pd", "kp": kp.tolist(), "kd": 0.5, "q_target": target.tolist()},
    }
    names = {
        **arrays,
        "q": keyed(info, q, "q", rng),
        "v": keyed(info, v, "v", rng),
        "controller": {
            **arrays["controller"],
            "kp": keyed(info, kp, "v", rng),
            "q_target": keyed(info, target, "q", rng),
        },
    }
    plain = _post(api, "solo12", "simulate", arrays)
    assert _post(api, "solo12", "simulate", names) == plain
    constant = {"q": q.tolist(), "v": v.tolist(), "dt": 1e-3, "steps": 3}
    assert _post(
        api, "solo12", "simulate", {**constant, "tau": keyed(info, tau, "v", rng)}
    ) == _post(api, "solo12", "simulate", {**constant, "tau": tau.tolist()})
    named = _post(api, "solo12", "simulate", {**arrays, "joint_names": True})
    assert named["t"] == plain["t"] and named["mechanical_energy"] == plain["mechanical_energy"]
    assert len(named["q"]) == 4 and named["q"][-1]["root_joint"] == plain["q"][-1][:7]
    assert named["v"][2]["root_joint"] == plain["v"][2][:6]


def test_binary_answers_can_be_keyed_by_name(api):
    body = binary.encode({"q": np.zeros(6), "joint_names": True})
    r = api.post(
        "/v1/robots/ur5/gravity", content=body, headers={"content-type": binary.BINARY_MEDIA_TYPE}
    )
    assert r.status_code == 200, r.text
    assert set(r.json()["gravity"]) == {
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    }
    r = api.post(
        "/v1/robots/ur5/gravity",
        content=body,
        headers={"content-type": binary.BINARY_MEDIA_TYPE, "accept": binary.BINARY_MEDIA_TYPE},
    )
    fields, arrays = binary.decode(r.content)  # arrays stay arrays; the names come once
    plain = api.post("/v1/robots/ur5/gravity", json={"q": [0.0] * 6}).json()["gravity"]
    assert arrays["gravity"].tolist() == plain
    layout = fields["joint_names"]["gravity"]
    assert [name for name, _, _ in layout] == [
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    ]
    by_name = r_json_named(api)
    assert {name: arrays["gravity"][start] for name, start, size in layout} == by_name


def r_json_named(api) -> dict:
    body = {"q": [0.0] * 6, "joint_names": True}
    return api.post("/v1/robots/ur5/gravity", json=body).json()["gravity"]


def _ur5(api, **change) -> dict:
    info = api.get("/v1/robots/ur5").json()
    q = {j["name"]: 0.0 for j in info["joints"]}
    q.update(change)
    return {k: v for k, v in q.items() if v is not None}


def test_missing_and_unknown_joint_names_are_listed(api):
    q = _ur5(api, elbow_joint=None, wrist_3_joint=None, elbo_joint=0.0)
    problem = assert_problem(
        api.post("/v1/robots/ur5/gravity", json={"q": q}), 422, "dimension_mismatch"
    )
    assert problem["missing"] == ["elbow_joint", "wrist_3_joint"]
    assert problem["unknown"] == ["elbo_joint"]
    assert "elbow_joint" in problem["detail"] and "elbo_joint" in problem["detail"]
    assert "GET /v1/robots/ur5" in problem["detail"]
    problem = assert_problem(
        api.post("/v1/robots/ur5/gravity", json={"q": _ur5(api, elbow_joint=None)}),
        422,
        "dimension_mismatch",
    )
    assert problem["missing"] == ["elbow_joint"] and problem["unknown"] == []
    huge = "x" * 200
    problem = assert_problem(
        api.post("/v1/robots/ur5/gravity", json={"q": _ur5(api, **{huge: 1.0})}),
        422,
        "dimension_mismatch",
    )
    assert huge not in problem["detail"] and len(problem["unknown"][0]) < 70


def test_wrong_entries_per_joint(api, catalog_registry):
    body = assert_problem(
        api.post("/v1/robots/ur5/gravity", json={"q": _ur5(api, elbow_joint=[0.0, 1.0])}),
        422,
        "dimension_mismatch",
    )
    assert "elbow_joint" in body["detail"] and "a number" in body["detail"]
    info = catalog_registry.catalog["solo12"].info()
    q = {j["name"]: 0.0 for j in info["joints"]}
    q["root_joint"] = [0.0] * 6  # needs 7: x, y, z and a quaternion
    body = assert_problem(
        api.post("/v1/robots/solo12/gravity", json={"q": q}), 422, "dimension_mismatch"
    )
    assert "7 numbers" in body["detail"]
    q["root_joint"] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0]
    assert_problem(
        api.post("/v1/robots/solo12/gravity", json={"q": q}), 422, "invalid_configuration"
    )


@pytest.mark.parametrize(
    "q",
    [
        [{"shoulder_pan_joint": 0.0}, [0.0] * 6],  # a batch mixing objects and arrays
        {"shoulder_pan_joint": [[0.0]]},
        {"shoulder_pan_joint": "0"},
        {"shoulder_pan_joint": None},
        {"shoulder_pan_joint": True},
    ],
)
def test_malformed_name_keyed_inputs_are_validation_errors(api, q):
    assert_problem(api.post("/v1/robots/ur5/gravity", json={"q": q}), 422, "validation_error")
    assert_problem(
        api.post("/v1/robots/ur5/gravity", json={"q": [0.0] * 6, "joint_names": 1}),
        422,
        "validation_error",
    )


# -- ROS-style inputs: angles for continuous joints, joints left out with "fill" -------------


def test_continuous_joints_take_their_angle(api, catalog_registry):
    """A JointState gives a continuous joint's angle θ; it stands for [cos θ, sin θ]."""
    theta = np.array([0.7, -2.9])
    arrays = {
        "q": np.concatenate([[np.cos(t), np.sin(t)] for t in theta]).tolist(),
        "v": [0.3, -1.1],
        "a": [2.0, 0.5],
    }
    plain = _post(api, "double_pendulum_continuous", "inverse-dynamics", arrays)
    for q in (
        {"joint1": theta[0], "joint2": theta[1]},
        {"joint1": [theta[0]], "joint2": [np.cos(theta[1]), np.sin(theta[1])]},
    ):
        named = _post(
            api,
            "double_pendulum_continuous",
            "inverse-dynamics",
            {**arrays, "q": {k: np.asarray(x).tolist() for k, x in q.items()}},
        )
        np.testing.assert_allclose(named["tau"], plain["tau"], rtol=1e-12, atol=1e-12)
    exact = _post(
        api,
        "double_pendulum_continuous",
        "gravity",
        {"q": {"joint1": float(theta[0]), "joint2": float(theta[1])}},
    )
    assert exact == _post(
        api,
        "double_pendulum_continuous",
        "gravity",
        {"q": [np.cos(theta[0]), np.sin(theta[0]), np.cos(theta[1]), np.sin(theta[1])]},
    )
    body = assert_problem(
        api.post(
            "/v1/robots/double_pendulum_continuous/gravity",
            json={"q": {"joint1": [1.0, 0.0, 0.0], "joint2": 0.0}},
        ),
        422,
        "dimension_mismatch",
    )
    assert "an angle or [cos θ, sin θ]" in body["detail"]


@pytest.mark.parametrize(
    ("robot", "fill", "left_out"),
    [
        ("panda", "neutral", ["panda_finger_joint1", "panda_finger_joint2"]),
        ("panda", "default", ["panda_finger_joint2", "panda_joint3"]),
        ("talos", "half_sitting", ["gripper_left_joint", "gripper_right_joint", "head_1_joint"]),
    ],
)
def test_joints_left_out_are_filled_from_the_named_configuration(
    api, catalog_registry, robot, fill, left_out
):
    """A JointState without the gripper: its q from the configuration `fill`, v and a zero."""
    r = catalog_registry.catalog[robot]
    info, rng = r.info(), np.random.default_rng(7)
    q, v, a = random_state(r.model, rng)
    base = (
        np.asarray(info["neutral_configuration"])
        if fill == "neutral"
        else r.reference_configurations[fill]
    )
    full_q, full_v, full_a = q.copy(), v.copy(), a.copy()
    for j in info["joints"]:
        if j["name"] in left_out:
            qs = slice(j["idx_q"], j["idx_q"] + j["nq"])
            vs = slice(j["idx_v"], j["idx_v"] + j["nv"])
            full_q[qs], full_v[vs], full_a[vs] = base[qs], 0.0, 0.0
    named = {
        k: {n: x for n, x in keyed(info, arr, k, rng).items() if n not in left_out}
        for k, arr in (("q", q), ("v", v), ("a", a))
    }
    got = _post(api, robot, "inverse-dynamics", {**named, "fill": fill})
    want = _post(
        api,
        robot,
        "inverse-dynamics",
        {"q": full_q.tolist(), "v": full_v.tolist(), "a": full_a.tolist()},
    )
    assert got == want
    batch = _post(
        api, robot, "inverse-dynamics", {**{k: [x, x] for k, x in named.items()}, "fill": fill}
    )
    assert batch["tau"] == [want["tau"], want["tau"]]
    problem = assert_problem(
        api.post(f"/v1/robots/{robot}/inverse-dynamics", json=named), 422, "dimension_mismatch"
    )
    assert problem["missing"] == [j["name"] for j in info["joints"] if j["name"] in left_out]
    assert '"fill"' in problem["detail"]


def test_fill_in_the_binary_form_and_unknown_fill_names(api):
    q = {"shoulder_pan_joint": 0.3, "elbow_joint": -1.0}
    full = [0.3, 0.0, -1.0, 0.0, 0.0, 0.0]
    want = _post(api, "ur5", "gravity", {"q": full})
    assert _post(api, "ur5", "gravity", {"q": q, "fill": "neutral"}) == want
    r = api.post(
        "/v1/robots/ur5/gravity",
        content=binary.encode({"q": np.array(full), "fill": "neutral"}),
        headers={"content-type": binary.BINARY_MEDIA_TYPE},
    )
    assert r.json() == want  # an option in __metadata__, ignored for arrays
    for body in ({"q": q, "fill": "standing"}, {"q": full, "fill": "standing"}):
        problem = assert_problem(
            api.post("/v1/robots/ur5/gravity", json=body), 422, "validation_error"
        )
        assert "'standing'" in problem["detail"] and "neutral" in problem["detail"]
    assert_problem(
        api.post("/v1/robots/ur5/gravity", json={"q": q, "fill": 3}), 422, "validation_error"
    )


def test_a_planar_root_takes_x_y_and_its_angle(api):
    from tests.helpers import planar_arm_urdf

    r = api.post(
        "/v1/robots",
        json={
            "urdf": planar_arm_urdf(0.5, 0.4, 2.0, 1.0),
            "root_joint": "planar",
            "name": "planar_root_names",
        },
    )
    assert r.status_code in (200, 201), r.text
    info = r.json()
    robot = info["id"]
    root = next(j for j in info["joints"] if j["type"] == "planar")
    others = [j["name"] for j in info["joints"] if j["type"] != "planar"]
    x, y, theta = 0.3, -0.2, 2.5
    full = {root["name"]: [x, y, np.cos(theta), np.sin(theta)], **dict.fromkeys(others, 0.4)}
    short = {root["name"]: [x, y, theta], **dict.fromkeys(others, 0.4)}
    v = {root["name"]: [0.1, 0.2, -0.3], **dict.fromkeys(others, 1.0)}
    got = _post(api, robot, "nonlinear-effects", {"q": short, "v": v})
    want = _post(api, robot, "nonlinear-effects", {"q": full, "v": v})
    np.testing.assert_allclose(
        got["nonlinear_effects"], want["nonlinear_effects"], rtol=1e-13, atol=1e-13
    )
    assert api.delete(f"/v1/robots/{robot}").status_code in (200, 204)
