"""Every catalog robot, through HTTP, in batch: the derivatives, centroidal momentum and
simulate answer, are finite, and agree with the service's own mass matrix, Jacobian-free
identities and in-process Pinocchio. Adding a robot to robots/catalog.toml adds its tests."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.registry.catalog import catalog_entries
from tests.helpers import random_state
from tests.service.dynamics.http_arrays import post

NAMES = [e.name for e in catalog_entries() if "urdf" in e.spec]


@pytest.mark.parametrize("name", NAMES)
def test_derivatives_centroidal_and_simulate_on_every_catalog_robot(api, catalog_registry, name):
    robot = catalog_registry.catalog[name]
    model = robot.model
    rng = np.random.default_rng(sum(map(ord, name)))
    q, v, a = (np.array(x) for x in zip(*(random_state(model, rng) for _ in range(2)), strict=True))
    M = post(api, name, "mass-matrix", q=q)["mass_matrix"]

    # ∂τ/∂a is M itself, ∂τ/∂q and ∂τ/∂v are nv × nv (tangent space)
    d = post(api, name, "inverse-dynamics-derivatives", q=q, v=v, a=a)
    assert d["dtau_dq"].shape == d["dtau_dv"].shape == (2, model.nv, model.nv)
    np.testing.assert_allclose(d["dtau_da"], M, rtol=1e-12, atol=1e-12)

    # centroidal momentum h = A_g(q) v, about the centre of mass, which is Pinocchio's
    c = post(api, name, "centroidal", q=q, v=v)
    np.testing.assert_allclose(
        np.einsum("nij,nj->ni", c["momentum_matrix"], v), c["momentum"], rtol=1e-9, atol=1e-9
    )
    data = model.createData()
    for i in range(2):
        np.testing.assert_allclose(
            c["center_of_mass"][i], pin.centerOfMass(model, data, q[i]), rtol=1e-12, atol=1e-12
        )

    # a short torque-free rollout: finite, q stays a valid configuration (unit quaternions)
    massless = any(w["code"] == "massless_subtree" for w in robot.warnings)
    if massless:  # forward dynamics needs M⁻¹: a clear 422, not a crash
        problem = post(api, name, "simulate", 422, q=q, v=v, dt=1e-3, steps=5)
        assert problem["code"] == "non_finite_result"
        return
    sim = post(api, name, "simulate", q=q, v=v, dt=1e-3, steps=5, integrator="rk4")
    assert sim["q"].shape == (2, 6, model.nq) and np.isfinite(sim["q"]).all()
    for state in sim["q"][:, -1]:
        np.testing.assert_allclose(pin.normalize(model, state.copy()), state, atol=1e-9)
