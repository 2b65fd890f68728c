"""Centroidal momentum, its matrix and the centre of mass: against in-process Pinocchio and,
independently, against the sum over bodies of each body's spatial momentum moved to the centre
of mass."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from tests.helpers import random_state

ROBOTS = ["ur5", "panda", "double_pendulum_continuous", "solo12", "talos"]


def _centroidal(api, robot: str, q: np.ndarray, v: np.ndarray) -> dict[str, np.ndarray]:
    r = api.post(f"/v1/robots/{robot}/centroidal", json={"q": q.tolist(), "v": v.tolist()})
    assert r.status_code == 200, r.text
    return {k: np.asarray(x) for k, x in r.json().items()}


def _sum_of_body_momenta(model, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(h about the centre of mass, world-aligned; c), from first principles: each body's
    momentum I_i v_i in its joint frame, moved to the world frame, summed, and moved from the
    world origin to the centre of mass c (angular part n_c = n_O − c × p)."""
    data = model.createData()
    pin.forwardKinematics(model, data, q, v)
    total = pin.Force.Zero()
    mass, first_moment = 0.0, np.zeros(3)
    for i in range(1, model.njoints):
        inertia = model.inertias[i]
        total += data.oMi[i].act(inertia * data.v[i])  # momentum about the world origin
        mass += inertia.mass
        first_moment += inertia.mass * data.oMi[i].act(inertia.lever)
    c = first_moment / mass
    linear = total.linear
    return np.concatenate([linear, total.angular - np.cross(c, linear)]), c


@pytest.mark.parametrize("robot", ROBOTS)
def test_centroidal_momentum_is_the_sum_of_body_momenta(api, catalog_registry, robot):
    model = catalog_registry.catalog[robot].model
    rng = np.random.default_rng(21)
    for _ in range(3):
        q, v, _ = random_state(model, rng)
        got = _centroidal(api, robot, q, v)
        h, c = _sum_of_body_momenta(model, q, v)
        scale = max(1.0, float(np.abs(h).max()))
        np.testing.assert_allclose(got["momentum"], h, rtol=0, atol=1e-10 * scale)
        np.testing.assert_allclose(got["center_of_mass"], c, rtol=0, atol=1e-12)
        np.testing.assert_allclose(
            got["momentum_matrix"] @ v, got["momentum"], rtol=0, atol=1e-10 * scale
        )
        # linear momentum = total mass × velocity of the centre of mass
        data = model.createData()
        pin.centerOfMass(model, data, q, v)
        vcom = data.vcom[0]
        np.testing.assert_allclose(
            got["momentum"][:3], pin.computeTotalMass(model) * vcom, rtol=0, atol=1e-10 * scale
        )


@pytest.mark.parametrize("robot", ROBOTS)
def test_centroidal_equals_in_process_pinocchio(api, catalog_registry, robot):
    model = catalog_registry.catalog[robot].model
    q, v, _ = random_state(model, np.random.default_rng(22))
    got = _centroidal(api, robot, q, v)
    data = model.createData()
    A = pin.computeCentroidalMap(model, data, q)
    assert got["momentum_matrix"].shape == (6, model.nv)
    np.testing.assert_allclose(got["momentum_matrix"], A, rtol=1e-12, atol=1e-12)
    data = model.createData()
    pin.computeCentroidalMomentum(model, data, q, v)
    np.testing.assert_allclose(got["momentum"], data.hg.vector, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(
        got["center_of_mass"], pin.centerOfMass(model, data, q), rtol=1e-12, atol=1e-12
    )


def test_centroidal_batch_equals_single_states(api, catalog_registry):
    model = catalog_registry.catalog["solo12"].model
    rng = np.random.default_rng(4)
    states = [random_state(model, rng)[:2] for _ in range(3)]
    qs, vs = (np.stack(x) for x in zip(*states, strict=True))
    batch = _centroidal(api, "solo12", qs, vs)
    assert batch["momentum"].shape == (3, 6)
    assert batch["momentum_matrix"].shape == (3, 6, model.nv)
    assert batch["center_of_mass"].shape == (3, 3)
    for i in range(3):
        single = _centroidal(api, "solo12", qs[i], vs[i])
        for key in single:
            np.testing.assert_array_equal(batch[key][i], single[key])
