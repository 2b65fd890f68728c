"""Contact dynamics, checked by physics: standing robots carry their weight, constraints hold,
impacts do not create energy, symmetric feet share the load, and the answers agree with
Pinocchio computed independently (frame Jacobians and accelerations, 6d contacts in LOCAL)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from tests.helpers import random_state

STANDING = {  # robot -> (feet, contact type)
    "solo12": (["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"], "point"),
    "anymal": (["LF_FOOT", "RF_FOOT", "LH_FOOT", "RH_FOOT"], "point"),
    "go1": (["FL_foot", "FR_foot", "RL_foot", "RR_foot"], "point"),
    "talos": (["left_sole_link", "right_sole_link"], "6d"),
}
G = 9.81


def contacts_of(robot: str) -> list[dict[str, str]]:
    feet, kind = STANDING[robot]
    return [{"frame": f, "type": kind} for f in feet]


def post(api, robot: str, quantity: str, **body) -> dict[str, np.ndarray]:
    body = {k: np.asarray(v).tolist() if isinstance(v, np.ndarray) else v for k, v in body.items()}
    r = api.post(f"/v1/robots/{robot}/{quantity}", json=body)
    assert r.status_code == 200, r.text
    return {k: np.asarray(x) for k, x in r.json().items()}


def mass_matrix(model, data, q: np.ndarray) -> np.ndarray:
    M = pin.crba(model, data, q)
    return np.triu(M) + np.triu(M, 1).T


def contact_jacobian(model, data, q: np.ndarray, contacts) -> np.ndarray:
    """Jc from the frames' LOCAL_WORLD_ALIGNED Jacobians, computed independently."""
    rows = []
    for c in contacts:
        J = pin.computeFrameJacobian(
            model, data, q, model.getFrameId(c["frame"]), pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        )
        rows.append(J[:3] if c["type"] == "point" else J)
    return np.vstack(rows)


def constraint_acceleration(model, data, q, v, a, contacts) -> np.ndarray:
    """Jc a + γ: each point contact's classical linear acceleration (world axes) and each 6d
    contact's spatial acceleration in its LOCAL frame, from forward kinematics (q, v, a)."""
    pin.forwardKinematics(model, data, q, v, a)
    pin.updateFramePlacements(model, data)
    out = []
    for c in contacts:
        fid = model.getFrameId(c["frame"])
        if c["type"] == "point":
            out.append(
                pin.getFrameClassicalAcceleration(
                    model, data, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
                ).linear
            )
        else:
            out.append(pin.getFrameAcceleration(model, data, fid, pin.ReferenceFrame.LOCAL).vector)
    return np.concatenate(out)


@pytest.mark.parametrize("robot", sorted(STANDING))
def test_standing_still_the_feet_carry_the_weight(api, catalog_registry, robot):
    """Reference posture, v = a = 0: zero root torque, no residual, vertical contact forces
    summing to m g (1e-9 relative) and no net horizontal force; the same τ in contact-dynamics
    gives zero acceleration and the same forces."""
    r = catalog_registry.catalog[robot]
    q, zero = r.default_configuration, np.zeros(r.nv)
    contacts = contacts_of(robot)
    out = post(api, robot, "contact-inverse-dynamics", q=q, v=zero, a=zero, contacts=contacts)
    weight = r.total_mass * G
    size = 3 if contacts[0]["type"] == "point" else 6
    forces = out["contact_forces"].reshape(len(contacts), size)
    assert out["tau"].shape == (r.nv,) and out["contact_forces"].shape == (len(contacts) * size,)
    np.testing.assert_array_equal(out["tau"][:6], 0.0)
    assert out["residual"] <= 1e-9 * weight
    assert abs(forces[:, 2].sum() - weight) <= 1e-9 * weight
    assert np.abs(forces[:, :2].sum(axis=0)).max() <= 1e-9 * weight
    assert (forces[:, 2] > 0).all()  # it stands on them, pushing the ground
    # gravity compensation holds the robot still under the contacts
    held = post(api, robot, "contact-dynamics", q=q, v=zero, tau=out["tau"], contacts=contacts)
    assert np.abs(held["a"]).max() <= 1e-9 * max(1.0, G)
    np.testing.assert_allclose(
        held["contact_forces"], out["contact_forces"], rtol=0, atol=1e-9 * weight
    )


@pytest.mark.parametrize("robot", sorted(STANDING))
def test_the_constraint_and_the_equation_of_motion_hold_at_random_states(catalog_registry, robot):
    """Jc a + J̇c v = 0 (1e-9) and M a + h = τ + Jcᵀ λ, with Jc, the accelerations and h
    computed independently of the contact code."""
    from service.dynamics.contacts import contact_dynamics
    from service.states import States

    r = catalog_registry.catalog[robot]
    model, data = r.model, r.model.createData()
    contacts = contacts_of(robot)
    rng = np.random.default_rng(7)
    for _ in range(4):
        q, v, tau = random_state(model, rng)
        out = contact_dynamics(
            r, States({"q": q[None], "v": v[None], "tau": tau[None]}, True), contacts=contacts
        )
        a, lam = out["a"][0], out["contact_forces"][0]
        drift = constraint_acceleration(model, data, q, v, a, contacts)
        assert np.abs(drift).max() <= 1e-9 * (1.0 + np.abs(a).max())
        M = mass_matrix(model, data, q)
        h = pin.nonLinearEffects(model, data, q, v)
        Jc = contact_jacobian(model, data, q, contacts)
        balance = M @ a + h - tau - Jc.T @ lam
        assert np.abs(balance).max() <= 1e-9 * (1.0 + np.abs(M @ a).max() + np.abs(h).max())


def test_6d_forces_are_local_world_aligned_wrenches_at_the_sole(catalog_registry):
    """Pinocchio's CONTACT_6D built in LOCAL gives the wrench in each sole's own axes: the
    answer is that wrench with force and torque rotated to the world's axes."""
    from service.dynamics.contacts import contact_dynamics
    from service.states import States

    r = catalog_registry.catalog["talos"]
    model, data = r.model, r.model.createData()
    q, v, tau = random_state(model, np.random.default_rng(3))
    contacts = contacts_of("talos")
    out = contact_dynamics(
        r, States({"q": q[None], "v": v[None], "tau": tau[None]}, False), contacts=contacts
    )
    models, datas = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    for c in contacts:
        f = model.frames[model.getFrameId(c["frame"])]
        cm = pin.RigidConstraintModel(
            pin.ContactType.CONTACT_6D, model, f.parentJoint, f.placement, pin.ReferenceFrame.LOCAL
        )
        models.append(cm)
        datas.append(cm.createData())
    pin.initConstraintDynamics(model, data, models, datas)
    a = pin.constraintDynamics(model, data, q, v, tau, models, datas)
    local = np.array(data.lambda_c).reshape(2, 6)
    pin.framesForwardKinematics(model, data, q)
    world = []
    for c, w in zip(contacts, local, strict=True):
        R = data.oMf[model.getFrameId(c["frame"])].rotation
        world.append(np.concatenate([R @ w[:3], R @ w[3:]]))
    np.testing.assert_allclose(out["a"][0], a, atol=1e-8)
    np.testing.assert_allclose(out["contact_forces"][0], np.concatenate(world), atol=1e-7)


def test_symmetric_feet_carry_equal_forces(api, catalog_registry):
    """solo12 is left-right symmetric: in its symmetric standing posture, mirrored feet carry
    mirrored forces (fx, fz equal, fy opposite), to 1e-9 of the weight."""
    r = catalog_registry.catalog["solo12"]
    q, zero = r.default_configuration.copy(), np.zeros(r.nv)
    q[:2] = 0.0  # on the plane of symmetry
    contacts = contacts_of("solo12")
    forces = post(
        api, "solo12", "contact-inverse-dynamics", q=q, v=zero, a=zero, contacts=contacts
    )["contact_forces"].reshape(4, 3)
    weight = r.total_mass * G
    for left, right in ((0, 1), (2, 3)):  # FL/FR, HL/HR
        np.testing.assert_allclose(
            forces[left] * [1, -1, 1], forces[right], rtol=0, atol=1e-9 * weight
        )


@pytest.mark.parametrize("robot", ["solo12", "talos"])
def test_impacts_do_not_create_energy(api, catalog_registry, robot):
    """Restitution 0: the contacts stop (Jc v⁺ = 0) and T⁺ ≤ T⁻; restitution 1: they bounce
    back (Jc v⁺ = −Jc v⁻) and T⁺ = T⁻; always M (v⁺ − v⁻) = Jcᵀ Λ."""
    r = catalog_registry.catalog[robot]
    model, data = r.model, r.model.createData()
    contacts = contacts_of(robot)
    rng = np.random.default_rng(11)
    for _ in range(3):
        q, v, _ = random_state(model, rng)
        M = mass_matrix(model, data, q)
        Jc = contact_jacobian(model, data, q, contacts)
        before = 0.5 * v @ M @ v
        for e in (0.0, 0.5, 1.0):
            out = post(api, robot, "impulse-dynamics", q=q, v=v, contacts=contacts, restitution=e)
            after_v, impulses = out["v"], out["contact_impulses"]
            after = 0.5 * after_v @ M @ after_v
            np.testing.assert_allclose(
                Jc @ after_v, -e * (Jc @ v), atol=1e-9 * (1 + np.abs(Jc @ v).max())
            )
            np.testing.assert_allclose(
                M @ (after_v - v), Jc.T @ impulses, atol=1e-8 * (1 + np.abs(M @ v).max())
            )
            assert after <= before * (1 + 1e-12)
            if e == 1.0:
                assert after == pytest.approx(before, rel=1e-9)


def test_inverse_dynamics_is_the_minimum_norm_solution(api, catalog_registry):
    """At a random state: M a + h = τ + Jcᵀ λ on every row (residual 0: four feet can hold
    any base wrench), λ is the pseudo-inverse solution of the root rows, and feeding τ back
    into contact-dynamics gives a (up to the forces' null space, which does not move)."""
    r = catalog_registry.catalog["solo12"]
    model, data = r.model, r.model.createData()
    contacts = contacts_of("solo12")
    q, v, a = random_state(model, np.random.default_rng(5))
    out = post(api, "solo12", "contact-inverse-dynamics", q=q, v=v, a=a, contacts=contacts)
    tau, lam = out["tau"], out["contact_forces"]
    rhs = pin.rnea(model, data, q, v, a)
    Jc = contact_jacobian(model, data, q, contacts)
    scale = 1 + np.abs(rhs).max()
    assert out["residual"] <= 1e-9 * scale
    np.testing.assert_array_equal(tau[:6], 0.0)
    np.testing.assert_allclose(tau + Jc.T @ lam, rhs, atol=1e-9 * scale)
    np.testing.assert_allclose(lam, np.linalg.pinv(Jc[:, :6].T) @ rhs[:6], atol=1e-9 * scale)


def test_the_residual_is_what_no_contact_force_can_do(api, catalog_registry):
    """One point foot cannot produce a torque about itself: asking solo12's base to spin
    about the vertical through that foot leaves a residual equal to the least-squares
    leftover of the root rows."""
    r = catalog_registry.catalog["solo12"]
    model, data = r.model, r.model.createData()
    q, v = r.default_configuration, np.zeros(r.nv)
    a = np.zeros(r.nv)
    a[5] = 1.0  # yaw acceleration of the base
    contacts = [{"frame": "FL_FOOT", "type": "point"}]
    out = post(api, "solo12", "contact-inverse-dynamics", q=q, v=v, a=a, contacts=contacts)
    B = contact_jacobian(model, data, q, contacts)[:, :6].T
    rhs = pin.rnea(model, data, q, v, a)[:6]
    lam = np.linalg.lstsq(B, rhs, rcond=None)[0]
    assert out["residual"] == pytest.approx(np.linalg.norm(B @ lam - rhs), rel=1e-9)
    assert out["residual"] > 1e-3


def test_a_fixed_base_robot_needs_no_contact_force(api, catalog_registry):
    """ur5 with its tool held: τ = M a + h (the actuators can do anything), λ = 0."""
    model = catalog_registry.catalog["ur5"].model
    q, v, a = random_state(model, np.random.default_rng(2))
    out = post(
        api,
        "ur5",
        "contact-inverse-dynamics",
        q=q,
        v=v,
        a=a,
        contacts=[{"frame": "tool0", "type": "6d"}],
    )
    np.testing.assert_allclose(
        out["tau"], pin.rnea(model, model.createData(), q, v, a), rtol=1e-12, atol=1e-12
    )
    np.testing.assert_array_equal(out["contact_forces"], np.zeros(6))
    assert out["residual"] == 0.0


def test_damping_answers_a_redundant_contact_set(api, catalog_registry):
    """The same foot twice is singular without damping; with μ > 0 the motion is that of the
    foot once and the force is shared equally between the two copies (minimum norm)."""
    r = catalog_registry.catalog["solo12"]
    q, v, tau = random_state(r.model, np.random.default_rng(9))
    once = post(
        api, "solo12", "contact-dynamics", q=q, v=v, tau=tau, contacts=[{"frame": "FL_FOOT"}]
    )
    twice = post(
        api,
        "solo12",
        "contact-dynamics",
        q=q,
        v=v,
        tau=tau,
        damping=1e-6,
        contacts=[{"frame": "FL_FOOT"}, {"frame": "FL_FOOT", "type": "point"}],
    )
    np.testing.assert_allclose(twice["a"], once["a"], atol=1e-6 * (1 + np.abs(once["a"]).max()))
    np.testing.assert_allclose(
        twice["contact_forces"][:3] + twice["contact_forces"][3:],
        once["contact_forces"],
        atol=1e-6 * (1 + np.abs(once["contact_forces"]).max()),
    )
    np.testing.assert_allclose(
        twice["contact_forces"][:3],
        twice["contact_forces"][3:],
        atol=1e-6 * (1 + np.abs(once["contact_forces"]).max()),
    )
