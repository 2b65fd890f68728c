"""Every catalog robot, through HTTP: identities of the equation of motion and agreement with
in-process Pinocchio. Adding a robot to robots/catalog.toml adds its tests."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.registry.catalog import catalog_entries
from tests.helpers import mass_matrix, random_state

NAMES = [e.name for e in catalog_entries()]
SDF_ONLY = {e.name for e in catalog_entries() if "urdf" not in e.spec}


def _post(api, robot, quantity, **body):
    r = api.post(
        f"/v1/robots/{robot}/{quantity}", json={k: np.asarray(x).tolist() for k, x in body.items()}
    )
    assert r.status_code == 200, r.text
    return {k: np.asarray(x) for k, x in r.json().items()}


def _close(actual, expected, rtol=1e-8):
    scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
    np.testing.assert_allclose(actual, expected, rtol=rtol, atol=rtol * scale)


def test_catalog_is_loaded(catalog_registry):
    loaded = set(catalog_registry.catalog)
    assert loaded | set(catalog_registry.catalog_failures) == set(NAMES)
    # Only descriptions this Pinocchio build cannot parse may be missing, and they say why.
    assert set(catalog_registry.catalog_failures) <= SDF_ONLY
    for reason in catalog_registry.catalog_failures.values():
        assert "SDF" in reason
    assert {
        "ur5",
        "talos",
        "panda",
        "solo12",
        "anymal",
        "hyq",
        "go1",
        "double_pendulum",
        "talos_arm",
        "talos_legs",
        "icub",
        "romeo",
        "tiago",
        "kinova",
        "z1",
    } <= loaded


def test_unavailable_robot_is_a_clear_404(api, catalog_registry):
    for name in catalog_registry.catalog_failures:
        r = api.get(f"/v1/robots/{name}")
        assert r.status_code == 404 and "could not be loaded" in r.json()["detail"]


@pytest.mark.parametrize("name", [n for n in NAMES if n not in SDF_ONLY])
def test_identities_and_pinocchio_agreement(api, catalog_registry, name):
    robot = catalog_registry.catalog[name]
    model = robot.model
    rng = np.random.default_rng(sum(map(ord, name)))  # seeded per robot
    q, v, a = random_state(model, rng)
    data = model.createData()

    M = _post(api, name, "mass-matrix", q=q)["mass_matrix"]
    g = _post(api, name, "gravity", q=q)["gravity"]
    cor = _post(api, name, "coriolis", q=q, v=v)
    C, Cv = cor["coriolis_matrix"], cor["coriolis_forces"]
    h = _post(api, name, "nonlinear-effects", q=q, v=v)["nonlinear_effects"]
    tau = _post(api, name, "inverse-dynamics", q=q, v=v, a=a)["tau"]

    # HTTP answers equal in-process Pinocchio on the same inputs.
    _close(M, mass_matrix(model, q), 1e-12)
    _close(g, pin.computeGeneralizedGravity(model, data, q), 1e-12)
    _close(C, pin.computeCoriolisMatrix(model, data, q, v), 1e-12)
    _close(h, pin.nonLinearEffects(model, data, q, v), 1e-12)
    _close(tau, pin.rnea(model, data, q, v, a), 1e-12)

    # M symmetric positive definite (robots whose description has a massless moving subtree
    # have a singular M; they carry that finding as a warning).
    np.testing.assert_array_equal(M, M.T)
    singular = any(w["code"] == "massless_subtree" for w in robot.warnings)
    if not singular:
        assert np.linalg.eigvalsh(M)[0] > 0

    # τ = M a + C v + g, C v + g = h, g = τ(q, 0, 0).
    _close(tau, M @ a + C @ v + g)
    _close(Cv, C @ v)
    _close(h, Cv + g)
    _close(
        _post(api, name, "inverse-dynamics", q=q, v=np.zeros_like(v), a=np.zeros_like(a))["tau"], g
    )

    # Ṁ = C + Cᵀ, with Ṁ by central finite differences along v on the configuration manifold.
    eps = 1e-6
    q_plus, q_minus = pin.integrate(model, q, v * eps), pin.integrate(model, q, -v * eps)
    M_pm = _post(api, name, "mass-matrix", q=np.stack([q_plus, q_minus]))["mass_matrix"]
    M_dot = (M_pm[0] - M_pm[1]) / (2 * eps)
    np.testing.assert_allclose(M_dot, C + C.T, atol=1e-5 * max(1.0, np.abs(M).max()))

    # forward(inverse(a)) = a.
    if not singular:
        a_back = _post(api, name, "forward-dynamics", q=q, v=v, tau=tau)["a"]
        cond = np.linalg.cond(M)
        np.testing.assert_allclose(a_back, a, atol=1e-13 * cond * max(1.0, np.abs(a).max()))
