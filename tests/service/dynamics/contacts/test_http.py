"""The contact endpoints over HTTP: answers equal the in-process computation, batches, joint
names, the binary form, the stream, simulate with contacts, suggested contact frames, and
every error the contract names."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.api.encoding import binary
from service.dynamics.contacts import (
    contact_dynamics,
    contact_inverse_dynamics,
    impulse_dynamics,
)
from service.states import States
from tests.helpers import random_state
from tests.service.api.problems.test_errors import assert_problem
from tests.service.dynamics.contacts.test_quantities import contacts_of, post

FEET = contacts_of("solo12")
COMPUTE = {
    "contact-dynamics": (contact_dynamics, ("q", "v", "tau")),
    "contact-inverse-dynamics": (contact_inverse_dynamics, ("q", "v", "a")),
    "impulse-dynamics": (impulse_dynamics, ("q", "v")),
}


def _batch(model, n: int, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    states = [random_state(model, rng) for _ in range(n)]
    return {
        "q": np.array([s[0] for s in states]),
        "v": np.array([s[1] for s in states]),
        "a": np.array([s[2] for s in states]),
        "tau": np.array([s[2] for s in states]),
    }


@pytest.mark.parametrize("quantity", sorted(COMPUTE))
def test_http_batches_equal_the_in_process_computation(api, catalog_registry, quantity):
    """A batch of 3 states: every answer has a leading axis of 3 and equals, bit for bit,
    the in-process function; single states give the rows of the batch."""
    r = catalog_registry.catalog["solo12"]
    fn, inputs = COMPUTE[quantity]
    arrays = {k: v for k, v in _batch(r.model, 3).items() if k in inputs}
    got = post(api, "solo12", quantity, contacts=FEET, **arrays)
    expected = fn(r, States(arrays, True), contacts=FEET)
    assert set(got) == set(expected)
    for name, value in expected.items():
        assert got[name].shape[0] == 3
        np.testing.assert_array_equal(got[name], value)
    one = post(api, "solo12", quantity, contacts=FEET, **{k: v[1] for k, v in arrays.items()})
    for name, value in expected.items():
        np.testing.assert_array_equal(one[name], value[1])


def test_joint_names_in_and_out(api, catalog_registry):
    """Inputs keyed by joint name give the same answer; `joint_names` keys τ by joint."""
    r = catalog_registry.catalog["solo12"]
    model = r.model
    q, v, a = random_state(model, np.random.default_rng(4))
    plain = post(api, "solo12", "contact-inverse-dynamics", q=q, v=v, a=a, contacts=FEET)

    def named(x: np.ndarray, dim: str) -> dict:
        out = {}
        for jid in range(1, model.njoints):
            jm = model.joints[jid]
            start, size = (jm.idx_q, jm.nq) if dim == "q" else (jm.idx_v, jm.nv)
            part = x[start : start + size].tolist()
            out[model.names[jid]] = part[0] if size == 1 else part
        return out

    r2 = api.post(
        "/v1/robots/solo12/contact-inverse-dynamics",
        json={
            "q": named(q, "q"),
            "v": named(v, "v"),
            "a": named(a, "v"),
            "contacts": FEET,
            "joint_names": True,
        },
    )
    assert r2.status_code == 200, r2.text
    body = r2.json()
    assert body["tau"]["FL_KFE"] == pytest.approx(
        plain["tau"][model.joints[model.getJointId("FL_KFE")].idx_v], abs=0
    )
    assert body["tau"]["root_joint"] == [0.0] * 6
    np.testing.assert_array_equal(body["contact_forces"], plain["contact_forces"])


def test_binary_form(api, catalog_registry):
    """The binary body (contacts among its non-array fields) answers what JSON answers."""
    r = catalog_registry.catalog["solo12"]
    arrays = {k: v for k, v in _batch(r.model, 2, seed=1).items() if k in ("q", "v", "tau")}
    body = binary.encode({**arrays, "contacts": FEET})
    res = api.post(
        "/v1/robots/solo12/contact-dynamics",
        content=body,
        headers={"content-type": binary.BINARY_MEDIA_TYPE, "accept": binary.BINARY_MEDIA_TYPE},
    )
    assert res.status_code == 200, res.text
    _fields, got = binary.decode(res.content)
    expected = post(api, "solo12", "contact-dynamics", contacts=FEET, **arrays)
    np.testing.assert_array_equal(got["a"], expected["a"])
    np.testing.assert_array_equal(got["contact_forces"], expected["contact_forces"])


def test_stream(api, catalog_registry):
    """The WebSocket stream answers contact quantities like the HTTP endpoints, and a bad
    contact is a problem after which the stream stays open."""
    r = catalog_registry.catalog["talos"]
    q, v, _ = random_state(r.model, np.random.default_rng(6))
    soles = contacts_of("talos")
    expected = post(api, "talos", "impulse-dynamics", q=q, v=v, contacts=soles)
    with api.websocket_connect("/v1/robots/talos/stream") as ws:
        ws.send_json(
            {"quantity": "impulse-dynamics", "q": q.tolist(), "v": v.tolist(), "contacts": soles}
        )
        got = ws.receive_json()
        np.testing.assert_array_equal(got["v"], expected["v"])
        ws.send_json(
            {
                "quantity": "impulse-dynamics",
                "q": q.tolist(),
                "v": v.tolist(),
                "contacts": [{"frame": "no_such_sole", "type": "6d"}],
            }
        )
        assert ws.receive_json()["code"] == "unknown_frame"
        ws.send_json(
            {"quantity": "impulse-dynamics", "q": q.tolist(), "v": v.tolist(), "contacts": soles}
        )
        np.testing.assert_array_equal(ws.receive_json()["v"], expected["v"])


def test_a_simulated_stand_keeps_the_feet_in_place(api, catalog_registry):
    """solo12 on its four feet for 1 s (dt = 1 ms) under PD control of its 12 joints toward
    its standing posture, from a perturbed velocity: every foot stays within 1 mm of where it
    started (checked by forward kinematics of the answer's q), the reported drift is that
    distance, and the robot stays up."""
    r = catalog_registry.catalog["solo12"]
    model, data = r.model, r.model.createData()
    q0 = r.default_configuration
    v0 = np.zeros(r.nv)
    v0[6:] = np.random.default_rng(0).normal(scale=0.5, size=12)
    out = post(
        api,
        "solo12",
        "simulate",
        q=q0,
        v=v0,
        dt=1e-3,
        steps=1000,
        contacts=FEET,
        controller={
            "type": "pd",
            "kp": 5.0,
            "kd": 0.1,
            "q_target": q0.tolist(),
            "gravity_compensation": True,
        },
    )
    fids = [model.getFrameId(c["frame"]) for c in FEET]
    pin.framesForwardKinematics(model, data, q0)
    start = np.array([data.oMf[f].translation for f in fids])
    moved = []
    for q in out["q"]:
        pin.framesForwardKinematics(model, data, q)
        moved.append(
            max(
                np.linalg.norm(data.oMf[f].translation - s)
                for f, s in zip(fids, start, strict=True)
            )
        )
    assert max(moved) < 1e-3
    np.testing.assert_allclose(out["constraint_drift"], moved, atol=1e-12)
    assert abs(out["q"][-1][2] - q0[2]) < 5e-3  # the base did not fall
    # and it came back to rest near its target
    assert np.abs(out["v"][-1]).max() < 0.1


def test_simulated_stand_under_gravity_compensation_alone_stays_at_rest(api, catalog_registry):
    """Contact-consistent gravity compensation with zero gains makes the reference posture an
    equilibrium: the state does not move, for either integrator."""
    r = catalog_registry.catalog["talos"]
    q0, v0 = r.default_configuration, np.zeros(r.nv)
    for integrator in ("semi-implicit-euler", "rk4"):
        out = post(
            api,
            "talos",
            "simulate",
            q=q0,
            v=v0,
            dt=1e-3,
            steps=50,
            contacts=contacts_of("talos"),
            integrator=integrator,
            controller={
                "type": "pd",
                "kp": 0.0,
                "kd": 0.0,
                "q_target": q0.tolist(),
                "gravity_compensation": True,
            },
        )
        assert np.abs(out["v"]).max() < 1e-8
        assert np.abs(out["constraint_drift"]).max() < 1e-10


def test_simulate_without_contacts_is_unchanged(api):
    out = api.post(
        "/v1/robots/ur5/simulate", json={"q": [0.0] * 6, "v": [0.0] * 6, "dt": 1e-3, "steps": 2}
    ).json()
    assert "constraint_drift" not in out


def test_catalog_legged_robots_suggest_feet_they_stand_on(api, catalog_registry):
    """Every catalog robot with `contact_frames`: each is a frame of the model, and with them
    as contacts the reference posture is held with no residual and positive normal forces."""
    listed = {rid: r for rid, r in catalog_registry.catalog.items() if r.contact_frames}
    assert {"solo12", "anymal", "go1", "talos", "a1", "hyq", "icub", "g1"} <= set(listed)
    for rid, r in listed.items():
        info = api.get(f"/v1/robots/{rid}").json()
        assert info["contact_frames"] == r.contact_frames
        names = {f["name"] for f in info["frames"]}
        assert {c["frame"] for c in r.contact_frames} <= names, rid
        zero = np.zeros(r.nv)
        out = post(
            api,
            rid,
            "contact-inverse-dynamics",
            q=r.default_configuration,
            v=zero,
            a=zero,
            contacts=r.contact_frames,
        )
        weight = r.total_mass * 9.81
        size = 3 if r.contact_frames[0]["type"] == "point" else 6
        fz = out["contact_forces"].reshape(len(r.contact_frames), size)[:, 2]
        assert out["residual"] <= 1e-9 * weight, rid
        assert (fz > 0).all(), rid
        assert abs(fz.sum() - weight) <= 1e-9 * weight, rid
    assert api.get("/v1/robots/ur5").json()["contact_frames"] == []


# ---- errors ------------------------------------------------------------------------------


def _zero(n: int) -> list[float]:
    return [0.0] * n


Q_SOLO = [0, 0, 0.24, 0, 0, 0, 1] + [0.0, 0.8, -1.6] * 4


def test_an_unknown_contact_frame_is_a_422_naming_it(api):
    r = api.post(
        "/v1/robots/solo12/contact-dynamics",
        json={
            "q": Q_SOLO,
            "v": _zero(18),
            "tau": _zero(18),
            "contacts": [*FEET[:2], {"frame": "XX_FOOT", "type": "point"}],
        },
    )
    body = assert_problem(r, 422, "unknown_frame")
    assert "XX_FOOT" in body["detail"] and "contacts[2].frame" in body["detail"]


@pytest.mark.parametrize("quantity", sorted(COMPUTE))
def test_a_contact_on_a_fixed_base_robots_world_is_a_422(api, quantity):
    body = {
        "q": _zero(6),
        "v": _zero(6),
        "a": _zero(6),
        "tau": _zero(6),
        "contacts": [{"frame": "base_link", "type": "6d"}],
    }
    body = {k: v for k, v in body.items() if k in (*COMPUTE[quantity][1], "contacts")}
    problem = assert_problem(
        api.post(f"/v1/robots/ur5/{quantity}", json=body), 422, "singular_configuration"
    )
    assert "base_link" in problem["detail"] and "world" in problem["detail"]


@pytest.mark.parametrize("quantity", sorted(COMPUTE))
def test_singular_contact_sets_are_422_naming_the_contacts(api, quantity):
    """Two 6d contacts on a 6-joint arm (ur5), and one foot twice (solo12): 422
    singular_configuration whose detail names the contacts and the damping option."""
    cases = [
        ("ur5", 6, 6, [{"frame": "tool0", "type": "6d"}, {"frame": "wrist_3_link", "type": "6d"}]),
        ("solo12", 19, 18, [FEET[0], FEET[0]]),
    ]
    for robot, _nq, nv, contacts in cases:
        if robot == "ur5" and quantity == "contact-inverse-dynamics":
            continue  # a fixed base needs no contact force: nothing to solve
        q = (
            [0.1, -1.0, 1.2, -0.4, 0.7, 0.2]
            if robot == "ur5"
            else [0, 0, 0.24, 0, 0, 0, 1] + [0.0, 0.8, -1.6] * 4
        )
        body = {"q": q, "v": _zero(nv), "a": _zero(nv), "tau": _zero(nv), "contacts": contacts}
        body = {k: v for k, v in body.items() if k in (*COMPUTE[quantity][1], "contacts")}
        problem = assert_problem(
            api.post(f"/v1/robots/{robot}/{quantity}", json=body), 422, "singular_configuration"
        )
        for c in contacts:
            assert c["frame"] in problem["detail"]
        assert "damping" in problem["detail"]
        ok = api.post(f"/v1/robots/{robot}/{quantity}", json={**body, "damping": 1e-6})
        assert ok.status_code == 200, ok.text


def test_singular_in_a_batch_names_the_state(api):
    q = [0, 0, 0.24, 0, 0, 0, 1] + [0.0, 0.8, -1.6] * 4
    problem = assert_problem(
        api.post(
            "/v1/robots/solo12/contact-dynamics",
            json={
                "q": [q, q],
                "v": [_zero(18)] * 2,
                "tau": [_zero(18)] * 2,
                "contacts": [FEET[1], FEET[1]],
            },
        ),
        422,
        "singular_configuration",
    )
    assert problem["detail"].startswith("state 0:")


@pytest.mark.parametrize(
    "contacts",
    [
        [],
        [{"frame": "FL_FOOT", "type": "line"}],
        [{"type": "point"}],
        [{"frame": "FL_FOOT", "type": "point", "mu": 0.7}],
        "FL_FOOT",
        None,
    ],
)
def test_malformed_contacts_are_validation_errors(api, contacts):
    body = {
        "q": [0, 0, 0.24, 0, 0, 0, 1] + [0.0] * 12,
        "v": _zero(18),
        "tau": _zero(18),
        "contacts": contacts,
    }
    assert_problem(
        api.post("/v1/robots/solo12/contact-dynamics", json=body), 422, "validation_error"
    )


@pytest.mark.parametrize("extra", [{"restitution": 1.5}, {"restitution": -0.1}, {"damping": -1.0}])
def test_out_of_range_options_are_validation_errors(api, extra):
    body = {"q": [0, 0, 0.24, 0, 0, 0, 1] + [0.0] * 12, "v": _zero(18), "contacts": FEET, **extra}
    assert_problem(
        api.post("/v1/robots/solo12/impulse-dynamics", json=body), 422, "validation_error"
    )


def test_missing_contacts_and_dimension_errors(api):
    assert_problem(
        api.post(
            "/v1/robots/solo12/contact-dynamics",
            json={"q": [0, 0, 0.24, 0, 0, 0, 1] + [0.0] * 12, "v": _zero(18), "tau": _zero(18)},
        ),
        422,
        "validation_error",
    )
    assert_problem(
        api.post(
            "/v1/robots/solo12/contact-dynamics",
            json={
                "q": [0, 0, 0.24, 0, 0, 0, 1] + [0.0] * 12,
                "v": _zero(17),
                "tau": _zero(18),
                "contacts": FEET,
            },
        ),
        422,
        "dimension_mismatch",
    )


def test_constraint_models_are_cached_per_robot_and_contact_set(catalog_registry):
    """The same (robot, contact set) gives the same cached models; another order, kind or
    robot gives others; no pin.Data is kept with them."""
    from service.dynamics.contacts import constraint_models

    solo, anymal = catalog_registry.catalog["solo12"], catalog_registry.catalog["anymal"]
    first = constraint_models(solo, FEET)
    assert constraint_models(solo, [dict(c) for c in FEET]) is first
    assert constraint_models(solo, FEET[::-1]) is not first
    assert constraint_models(solo, [{**c, "type": "6d"} for c in FEET]).size == 24
    assert first.size == 12 and [r.start for r in first.rows] == [0, 3, 6, 9]
    other = constraint_models(anymal, contacts_of("anymal"))
    assert other is not first
    assert not any("Data" in type(value).__name__ for value in vars(first).values())
