"""The bundled planar arm and an uploaded arm against the hand-derived closed form."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers import planar_arm_closed_form, planar_arm_urdf

RTOL = 1e-8
BUNDLED = (1.0, 0.7, 2.0, 1.5)  # l1, l2, m1, m2 of robots/textbook/planar_arm.urdf


def _post(api, robot, quantity, **body):
    r = api.post(
        f"/v1/robots/{robot}/{quantity}", json={k: np.asarray(x).tolist() for k, x in body.items()}
    )
    assert r.status_code == 200, r.text
    return {k: np.asarray(x) for k, x in r.json().items()}


def _check_all_quantities(api, robot, params, rng):
    l1, l2, m1, m2 = params
    for _ in range(5):
        q, v, a = rng.uniform(-3, 3, 2), rng.normal(size=2), rng.normal(size=2)
        M, C, g = planar_arm_closed_form(l1, l2, m1, m2, q, v)
        tau = M @ a + C @ v + g
        scale = np.abs(M).max()
        np.testing.assert_allclose(
            _post(api, robot, "mass-matrix", q=q)["mass_matrix"], M, rtol=RTOL, atol=RTOL * scale
        )
        np.testing.assert_allclose(
            _post(api, robot, "gravity", q=q)["gravity"], g, rtol=RTOL, atol=RTOL * np.abs(g).max()
        )
        cor = _post(api, robot, "coriolis", q=q, v=v)
        np.testing.assert_allclose(cor["coriolis_matrix"], C, rtol=RTOL, atol=RTOL * scale)
        np.testing.assert_allclose(cor["coriolis_forces"], C @ v, rtol=RTOL, atol=RTOL * scale)
        np.testing.assert_allclose(
            _post(api, robot, "nonlinear-effects", q=q, v=v)["nonlinear_effects"],
            C @ v + g,
            rtol=RTOL,
            atol=RTOL * np.abs(g).max(),
        )
        np.testing.assert_allclose(
            _post(api, robot, "inverse-dynamics", q=q, v=v, a=a)["tau"],
            tau,
            rtol=RTOL,
            atol=RTOL * np.abs(tau).max(),
        )
        np.testing.assert_allclose(
            _post(api, robot, "forward-dynamics", q=q, v=v, tau=tau)["a"], a, rtol=1e-7, atol=1e-8
        )


def test_bundled_planar_arm_matches_hand_derivation(api):
    _check_all_quantities(api, "planar_arm", BUNDLED, np.random.default_rng(1))


def test_bundled_planar_arm_info(api):
    info = api.get("/v1/robots/planar_arm").json()
    assert info["total_mass"] == pytest.approx(3.5)
    assert [j["name"] for j in info["joints"]] == ["shoulder", "elbow"]
    assert [j["idx_q"] for j in info["joints"]] == [0, 1]


@pytest.mark.parametrize("params", [(0.5, 0.3, 1.0, 0.25), (2.0, 1.5, 4.0, 3.0)])
def test_uploaded_arm_matches_hand_derivation(api, params):
    r = api.post("/v1/robots", json={"urdf": planar_arm_urdf(*params), "name": "textbook arm"})
    assert r.status_code in (200, 201), r.text
    info = r.json()
    assert info["source"] == "upload" and info["name"] == "textbook arm"
    assert info["total_mass"] == pytest.approx(params[2] + params[3])
    _check_all_quantities(api, info["id"], params, np.random.default_rng(2))


def test_arm_at_rest_horizontal_gravity_torque(api):
    """Both links horizontal: the shoulder holds (m1 l1 + m2 (l1 + l2)) g0, the elbow m2 l2 g0."""
    g = _post(api, "planar_arm", "gravity", q=[0.0, 0.0])["gravity"]
    np.testing.assert_allclose(g, [(2.0 * 1.0 + 1.5 * 1.7) * 9.81, 1.5 * 0.7 * 9.81], rtol=1e-12)
