"""Damping μ > 0 of the contact quantities: answers converge to the constraint tolerance or
are refused. Checked against the constraint equations computed independently (Jc a + γ = 0,
Jc v⁺ = −e Jc v⁻, M a + h = τ + Jcᵀ λ) and against the undamped answer where Jc has full
rank."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.dynamics.contacts.solve import CONSTRAINT_ACCURACY, MAX_DAMPING
from tests.helpers import random_state
from tests.service.api.problems.test_errors import assert_problem
from tests.service.dynamics.contacts.test_quantities import (
    constraint_acceleration,
    contact_jacobian,
    contacts_of,
    mass_matrix,
    post,
)

FEET = contacts_of("solo12")
REDUNDANT = [
    {"frame": "FL_FOOT", "type": "point"},
    {"frame": "FL_FOOT", "type": "point"},
    {"frame": "HR_FOOT", "type": "point"},
]
SOLES = contacts_of("talos")


@pytest.mark.parametrize("mu", [1e-6, 1e-3, 1e-1])
def test_damped_answers_are_the_undamped_ones_where_jc_has_full_rank(api, catalog_registry, mu):
    """solo12 on four feet (Jc of full rank): with damping, contact-dynamics,
    impulse-dynamics and contact-inverse-dynamics answer what they answer without, to the
    constraint tolerance (an impact solved once would be off by about μ Λ)."""
    r = catalog_registry.catalog["solo12"]
    q, v, x = random_state(r.model, np.random.default_rng(21))
    for quantity, extra, answers in (
        ("contact-dynamics", {"tau": x}, ("a", "contact_forces")),
        ("impulse-dynamics", {"restitution": 0.5}, ("v", "contact_impulses")),
        ("contact-inverse-dynamics", {"a": x}, ("tau", "contact_forces", "residual")),
    ):
        exact = post(api, "solo12", quantity, q=q, v=v, contacts=FEET, **extra)
        damped = post(api, "solo12", quantity, q=q, v=v, contacts=FEET, damping=mu, **extra)
        for name in answers:
            scale = 1.0 + np.abs(exact[name]).max()
            np.testing.assert_allclose(
                damped[name], exact[name], rtol=0, atol=1e-6 * scale, err_msg=f"{quantity} {name}"
            )


@pytest.mark.parametrize("mu", [1e-6, 1e-2, 1.0])
def test_damped_answers_of_a_redundant_set_satisfy_the_constraint_equations(
    api, catalog_registry, mu
):
    """A foot listed twice (Jc rank-deficient): Jc a + γ = 0 and M a + h = τ + Jcᵀ λ;
    Jc v⁺ = −e Jc v⁻ and M (v⁺ − v⁻) = Jcᵀ Λ, each to the documented tolerance; the copies
    share the force equally (minimum norm)."""
    r = catalog_registry.catalog["solo12"]
    model, data = r.model, r.model.createData()
    q, v, tau = random_state(model, np.random.default_rng(9))
    M, h = mass_matrix(model, data, q), pin.nonLinearEffects(model, data, q, v)
    Jc = contact_jacobian(model, data, q, REDUNDANT)
    out = post(api, "solo12", "contact-dynamics", q=q, v=v, tau=tau, contacts=REDUNDANT, damping=mu)
    a, lam = out["a"], out["contact_forces"]
    gamma = constraint_acceleration(model, data, q, v, np.zeros(r.nv), REDUNDANT)
    violation = constraint_acceleration(model, data, q, v, a, REDUNDANT)
    assert np.abs(violation).max() <= 10 * CONSTRAINT_ACCURACY * (1 + np.abs(gamma).max())
    np.testing.assert_allclose(
        M @ a + h, tau + Jc.T @ lam, rtol=0, atol=1e-9 * (1 + np.abs(h).max() + np.abs(tau).max())
    )
    np.testing.assert_allclose(lam[:3], lam[3:6], rtol=0, atol=1e-6 * np.abs(lam).max())
    e = 0.5
    hit = post(
        api, "solo12", "impulse-dynamics", q=q, v=v, contacts=REDUNDANT, damping=mu, restitution=e
    )
    r_hs = -(1 + e) * (Jc @ v)
    np.testing.assert_allclose(
        Jc @ hit["v"],
        -e * (Jc @ v),
        rtol=0,
        atol=10 * CONSTRAINT_ACCURACY * (1 + np.abs(r_hs).max()),
    )
    np.testing.assert_allclose(
        M @ (hit["v"] - v),
        Jc.T @ hit["contact_impulses"],
        rtol=0,
        atol=1e-9 * (1 + np.abs(M @ v).max()),
    )


@pytest.mark.parametrize("quantity", ["contact-dynamics", "impulse-dynamics"])
def test_damping_too_large_to_converge_is_refused_with_the_residual(
    api, catalog_registry, quantity
):
    """Talos on its soles with μ = 1 (large against its Jc M⁻¹ Jcᵀ): the iterations do not
    reach the tolerance, so the answer is a 422 singular_configuration giving the violation
    reached (a 200 with forces violating the constraint before)."""
    r = catalog_registry.catalog["talos"]
    q, v, tau = random_state(r.model, np.random.default_rng(9))
    body = {"q": q.tolist(), "v": v.tolist(), "contacts": SOLES, "damping": MAX_DAMPING}
    if quantity == "contact-dynamics":
        body["tau"] = tau.tolist()
    problem = assert_problem(
        api.post(f"/v1/robots/talos/{quantity}", json=body), 422, "singular_configuration"
    )
    assert "did not converge" in problem["detail"] and "smaller damping" in problem["detail"]
    assert problem["residual"] > CONSTRAINT_ACCURACY
    assert problem["contacts"] == ["left_sole_link", "right_sole_link"]


@pytest.mark.parametrize("damping", [MAX_DAMPING * 1.5, 1e6, -1e-9])
def test_damping_is_bounded(api, damping):
    body = {
        "q": [0, 0, 0.24, 0, 0, 0, 1] + [0.0, 0.8, -1.6] * 4,
        "v": [0.0] * 18,
        "tau": [0.0] * 18,
        "contacts": FEET,
        "damping": damping,
    }
    problem = assert_problem(
        api.post("/v1/robots/solo12/contact-dynamics", json=body), 422, "validation_error"
    )
    assert "damping" in problem["detail"]


def test_the_openapi_document_shows_the_bounds_checked_by_the_physics(api):
    """The bounds live in the physics; the request schema shows the same numbers."""
    schemas = api.get("/openapi.json").json()["components"]["schemas"]
    damping = schemas["ContactDynamicsRequest"]["properties"]["damping"]
    assert (damping["minimum"], damping["maximum"]) == (0.0, MAX_DAMPING)
    contact = schemas["Contact"]["properties"]
    assert contact["type"]["enum"] == ["point", "6d"]
    restitution = schemas["ImpulseDynamicsRequest"]["properties"]["restitution"]
    assert (restitution["minimum"], restitution["maximum"]) == (0.0, 1.0)


def test_a_damped_rollout_on_a_nearly_singular_set(api, catalog_registry):
    """solo8's four point feet (legs without abduction joints: Jc nearly rank-deficient),
    perturbed joint velocities, PD with compensation, 300 steps: with μ = 1e-6 the rollout
    holds its feet (drift under 1 mm, recomputed from q); with μ = 1e-3, too large for its
    nearly singular directions, the iterations miss the rollout tolerance: a 422 giving the
    residual, where an unconverged trajectory was answered before."""
    r = catalog_registry.catalog["solo8"]
    model, data = r.model, r.model.createData()
    feet = [{"frame": f, "type": "point"} for f in ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")]
    q0 = r.default_configuration
    v0 = np.zeros(r.nv)
    v0[6:] = np.random.default_rng(0).normal(scale=0.5, size=r.nv - 6)
    body = {
        "q": q0.tolist(),
        "v": v0.tolist(),
        "dt": 1e-3,
        "steps": 300,
        "contacts": feet,
        "controller": {
            "type": "pd",
            "kp": 5.0,
            "kd": 0.1,
            "q_target": q0.tolist(),
            "gravity_compensation": True,
        },
    }
    out = post(api, "solo8", "simulate", damping=1e-6, **body)
    fids = [model.getFrameId(c["frame"]) for c in feet]
    pin.framesForwardKinematics(model, data, q0)
    start = [data.oMf[f].translation.copy() for f in fids]
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
    problem = assert_problem(
        api.post("/v1/robots/solo8/simulate", json={**body, "damping": 1e-3}),
        422,
        "singular_configuration",
    )
    assert "did not converge" in problem["detail"] and problem["residual"] > 0
