"""GET /v1/robots/{id}/inertias: the bundled cube_pendulum's hand-computed numbers, and on every
catalog robot the parallel-axis theorem, the principal decomposition and the triangle
inequality (or the robot's warnings naming the link)."""

from __future__ import annotations

import numpy as np
import pytest

from service.registry.catalog import catalog_entries
from tests.service.dynamics.http_arrays import post

NAMES = [e.name for e in catalog_entries() if "urdf" in e.spec]
CUBE_M, CUBE_A, CUBE_C = 2.4, 0.2, np.array([0.3, 0.1, -0.2])
BOX_M, BOX_SIDES, BOX_C, BOX_TURN = 1.5, np.array([0.1, 0.2, 0.4]), np.array([0, 0.25, 0]), 30.0


def _rot_z(degrees: float) -> np.ndarray:
    t = np.radians(degrees)
    return np.array([[np.cos(t), -np.sin(t), 0], [np.sin(t), np.cos(t), 0], [0, 0, 1]])


def test_cube_pendulum_closed_form(api):
    got = api.get("/v1/robots/cube_pendulum/inertias").json()
    cube, box = got["bodies"]
    assert (cube["name"], cube["joint"], cube["links"]) == ("cube", "hinge", ["cube"])
    assert (box["name"], box["joint"], box["links"]) == ("box", "swing", ["box", "tool"])
    assert got["total_mass"] == pytest.approx(CUBE_M + BOX_M, abs=1e-15)

    # the cube: m a²/6 on the diagonal at its centre, whatever the rpy of its inertial frame
    assert cube["mass"] == pytest.approx(CUBE_M, abs=1e-15)
    np.testing.assert_allclose(cube["center_of_mass"], CUBE_C, atol=1e-15)
    np.testing.assert_allclose(
        cube["inertia_at_center_of_mass"], CUBE_M * CUBE_A**2 / 6 * np.eye(3), atol=1e-15
    )
    np.testing.assert_allclose(cube["principal_moments"], [0.016] * 3, atol=1e-15)
    # at the joint: I_c + m (|c|² 1 − c cᵀ), written out by hand
    np.testing.assert_allclose(
        cube["inertia_at_joint"],
        [[0.136, -0.072, 0.144], [-0.072, 0.328, 0.048], [0.144, 0.048, 0.256]],
        atol=1e-15,
    )

    # the box: principal moments m (b² + c²)/12 ... about the columns of Rz(30°)
    a, b, c = BOX_SIDES
    moments = BOX_M / 12 * np.array([b**2 + c**2, a**2 + c**2, a**2 + b**2])
    np.testing.assert_allclose(box["principal_moments"], np.sort(moments), atol=1e-15)
    axes = np.asarray(box["principal_axes"])
    expected_axes = _rot_z(BOX_TURN)[:, np.argsort(moments)]
    np.testing.assert_allclose(np.abs(np.sum(axes * expected_axes, axis=0)), 1.0, atol=1e-12)
    np.testing.assert_allclose(box["center_of_mass"], BOX_C, atol=1e-15)
    turned = _rot_z(BOX_TURN) @ np.diag(moments) @ _rot_z(BOX_TURN).T
    np.testing.assert_allclose(box["inertia_at_center_of_mass"], turned, atol=1e-15)
    np.testing.assert_allclose(
        np.asarray(box["inertia_at_joint"]) - turned,
        BOX_M * np.diag([0.25**2, 0, 0.25**2]),
        atol=1e-15,
    )


def test_cube_pendulum_mass_matrix_from_the_inertias(api):
    """At q = 0, M[0, 0] is the inertia of both bodies about the hinge axis y through the
    origin, and M[1, 1] the box's about the swing axis x through its joint (any q)."""
    M = post(api, "cube_pendulum", "mass-matrix", q=[0.0, 0.0])["mass_matrix"]
    box_yy_at_hinge = 0.0221875 + BOX_M * (0.5**2 + BOX_C[2] ** 2)  # Rz(30°) I_c, then + m d²
    assert M[0, 0] == pytest.approx(0.328 + box_yy_at_hinge, abs=1e-14)
    for q in ([0.0, 0.0], [0.4, -1.3]):
        M = post(api, "cube_pendulum", "mass-matrix", q=q)["mass_matrix"]
        assert M[1, 1] == pytest.approx(0.025 * 0.75 + 0.02125 * 0.25 + BOX_M * 0.25**2, abs=1e-14)


@pytest.mark.parametrize("name", NAMES)
def test_inertias_on_every_catalog_robot(api, catalog_registry, name):
    robot = catalog_registry.catalog[name]
    model = robot.model
    r = api.get(f"/v1/robots/{name}/inertias")
    assert r.status_code == 200, r.text
    got = r.json()
    info = api.get(f"/v1/robots/{name}").json()
    bodies = got["bodies"]
    assert [b["joint"] for b in bodies] == [j["name"] for j in info["joints"]]
    masses = np.array([b["mass"] for b in bodies])
    assert got["total_mass"] == pytest.approx(masses.sum(), rel=1e-12)
    assert got["total_mass"] == pytest.approx(info["total_mass"], rel=1e-12)
    warned = {
        w["name"]
        for w in robot.warnings
        if w["code"] in ("triangle_inequality", "negative_principal_moment")
    }
    frame_names = {f["name"] for f in info["frames"]}
    for jid, body in enumerate(bodies, start=1):
        m, c = body["mass"], np.asarray(body["center_of_mass"])
        I_c = np.asarray(body["inertia_at_center_of_mass"])
        I_o = np.asarray(body["inertia_at_joint"])
        moments, R = np.asarray(body["principal_moments"]), np.asarray(body["principal_axes"])
        assert set(body["links"]) <= frame_names and body["name"] in body["links"]
        # the model's own numbers, in the joint frame
        assert m == pytest.approx(model.inertias[jid].mass, abs=1e-15)
        np.testing.assert_allclose(c, model.inertias[jid].lever, atol=1e-15)
        np.testing.assert_allclose(I_c, model.inertias[jid].inertia, atol=1e-15)
        scale = max(float(np.abs(I_o).max()), 1e-300)
        # parallel axis: I_o = I_c + m (|c|² 1 − c cᵀ); and a rotation R with I_c = R Λ Rᵀ
        np.testing.assert_allclose(
            I_o, I_c + m * (c @ c * np.eye(3) - np.outer(c, c)), atol=1e-14 * scale
        )
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(
            R @ np.diag(moments) @ R.T, I_c, atol=1e-12 * max(float(np.abs(I_c).max()), 1e-300)
        )
        assert np.all(np.diff(moments) >= 0)
        # physical bodies: non-negative moments and I_1 + I_2 ≥ I_3, or a warning names a link
        # of the body (the same tolerances as the upload check)
        tol = 1e-6 * moments.sum() + 1e-12
        physical = (
            moments[0] >= -(1e-6 * moments[2] + 1e-12)
            and moments[0] + moments[1] >= moments[2] - tol
        )
        assert physical or warned & set(body["links"]), (name, body["name"], moments)


def test_a_violation_is_found_where_the_catalog_warns(api, catalog_registry):
    """The triangle test above is not vacuous: romeo_small has warned links that violate it."""
    bodies = api.get("/v1/robots/romeo_small/inertias").json()["bodies"]
    violating = [
        b["name"]
        for b in bodies
        if sum(b["principal_moments"][:2]) < b["principal_moments"][2] * (1 - 1e-6)
    ]
    warned = {w["name"] for w in catalog_registry.catalog["romeo_small"].warnings}
    assert violating and set(violating) <= warned
