"""Analytical derivatives against central finite differences of the service's own inverse and
forward dynamics, on the tangent space (q ⊕ δ = pin.integrate) for free-flyer and continuous
joints; ∂τ/∂a = M and ∂a/∂τ = M⁻¹ against the mass-matrix endpoint."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from tests.helpers import random_state

ROBOTS = ["ur5", "panda", "double_pendulum_continuous", "solo12"]
H = 1e-6  # finite-difference step


def _post(api, robot: str, path: str, **arrays: np.ndarray) -> dict[str, np.ndarray]:
    r = api.post(
        f"/v1/robots/{robot}/{path}", json={k: np.asarray(v).tolist() for k, v in arrays.items()}
    )
    assert r.status_code == 200, r.text
    return {k: np.asarray(v) for k, v in r.json().items()}


def _central_differences(api, robot, model, path, out, q, v, x, xname):
    """∂out/∂q, ∂out/∂v, ∂out/∂x by central differences: one batch request of 6 nv states."""
    nv = model.nv
    eye = np.eye(nv)
    qs, vs, xs = [], [], []
    for which in ("q", "v", "x"):
        for j in range(nv):
            for sign in (1.0, -1.0):
                d = sign * H * eye[j]
                qs.append(pin.integrate(model, q, d) if which == "q" else q)
                vs.append(v + d if which == "v" else v)
                xs.append(x + d if which == "x" else x)
    got = _post(api, robot, path, q=np.array(qs), v=np.array(vs), **{xname: np.array(xs)})[out]
    diffs = (got[0::2] - got[1::2]) / (2 * H)  # (3 nv, nv): row j is column j of a Jacobian
    return diffs[:nv].T, diffs[nv : 2 * nv].T, diffs[2 * nv :].T


def _close(analytic: np.ndarray, numeric: np.ndarray) -> None:
    scale = max(1.0, float(np.abs(analytic).max()))
    np.testing.assert_allclose(analytic, numeric, rtol=0, atol=2e-6 * scale)


@pytest.mark.parametrize("robot", ROBOTS)
def test_inverse_dynamics_derivatives_equal_finite_differences(api, catalog_registry, robot):
    model = catalog_registry.catalog[robot].model
    rng = np.random.default_rng(11)
    for _ in range(2):
        q, v, a = random_state(model, rng)
        got = _post(api, robot, "inverse-dynamics-derivatives", q=q, v=v, a=a)
        assert all(got[k].shape == (model.nv, model.nv) for k in got)
        dq, dv, da = _central_differences(
            api, robot, model, "inverse-dynamics", "tau", q, v, a, "a"
        )
        _close(got["dtau_dq"], dq)
        _close(got["dtau_dv"], dv)
        _close(got["dtau_da"], da)
        M = _post(api, robot, "mass-matrix", q=q)["mass_matrix"]
        np.testing.assert_allclose(got["dtau_da"], M, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(got["dtau_da"], got["dtau_da"].T)


@pytest.mark.parametrize("robot", ROBOTS)
def test_forward_dynamics_derivatives_equal_finite_differences(api, catalog_registry, robot):
    model = catalog_registry.catalog[robot].model
    rng = np.random.default_rng(12)
    for _ in range(2):
        q, v, tau = random_state(model, rng)
        got = _post(api, robot, "forward-dynamics-derivatives", q=q, v=v, tau=tau)
        dq, dv, dtau = _central_differences(
            api, robot, model, "forward-dynamics", "a", q, v, tau, "tau"
        )
        _close(got["da_dq"], dq)
        _close(got["da_dv"], dv)
        _close(got["da_dtau"], dtau)
        M = _post(api, robot, "mass-matrix", q=q)["mass_matrix"]
        np.testing.assert_allclose(got["da_dtau"] @ M, np.eye(model.nv), atol=1e-8)
        np.testing.assert_array_equal(got["da_dtau"], got["da_dtau"].T)


def test_free_flyer_derivative_is_on_the_tangent_space(api, catalog_registry):
    """For solo12 (nq = nv + 1) ∂τ/∂q has nv columns, and moving the base along a tangent
    direction δ changes τ by ∂τ/∂q δ to first order."""
    model = catalog_registry.catalog["solo12"].model
    rng = np.random.default_rng(5)
    q, v, a = random_state(model, rng)
    got = _post(api, "solo12", "inverse-dynamics-derivatives", q=q, v=v, a=a)
    assert got["dtau_dq"].shape == (model.nv, model.nv) and model.nq == model.nv + 1
    delta = np.zeros(model.nv)
    delta[3:6] = rng.normal(size=3) * 1e-4  # a small rotation of the base
    taus = _post(
        api,
        "solo12",
        "inverse-dynamics",
        q=np.array([q, pin.integrate(model, q, delta)]),
        v=np.array([v, v]),
        a=np.array([a, a]),
    )["tau"]
    np.testing.assert_allclose(
        taus[1] - taus[0], got["dtau_dq"] @ delta, rtol=1e-3, atol=1e-8 * np.abs(taus).max()
    )


@pytest.mark.parametrize(
    "path, x", [("inverse-dynamics-derivatives", "a"), ("forward-dynamics-derivatives", "tau")]
)
def test_derivatives_batch_equals_single_states(api, catalog_registry, path, x):
    model = catalog_registry.catalog["talos"].model
    rng = np.random.default_rng(3)
    states = [random_state(model, rng) for _ in range(3)]
    qs, vs, xs = (np.stack(s) for s in zip(*states, strict=True))
    batch = _post(api, "talos", path, q=qs, v=vs, **{x: xs})
    for i in range(3):
        single = _post(api, "talos", path, q=qs[i], v=vs[i], **{x: xs[i]})
        for key in single:
            assert batch[key].shape == (3, model.nv, model.nv)
            np.testing.assert_array_equal(batch[key][i], single[key])


def test_derivatives_equal_in_process_pinocchio(api, catalog_registry):
    model = catalog_registry.catalog["talos"].model
    q, v, a = random_state(model, np.random.default_rng(8))
    got = _post(api, "talos", "inverse-dynamics-derivatives", q=q, v=v, a=a)
    data = model.createData()  # the answers are views of its buffers: keep it alive
    want = pin.computeRNEADerivatives(model, data, q, v, a)
    np.testing.assert_allclose(got["dtau_dq"], want[0], rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(got["dtau_dv"], want[1], rtol=1e-12, atol=1e-10)
    got = _post(api, "talos", "forward-dynamics-derivatives", q=q, v=v, tau=a)
    want = pin.computeABADerivatives(model, data, q, v, a)
    np.testing.assert_allclose(got["da_dq"], want[0], rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(got["da_dv"], want[1], rtol=1e-10, atol=1e-8)
