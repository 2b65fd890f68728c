"""simulate: energy conservation, PD convergence on the configuration manifold, the integration
schemes against in-process re-implementations, batches, limits and every error."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service import dynamics
from service.api.routes import dynamics as routes
from tests.helpers import random_state
from tests.service.api.problems.test_errors import assert_problem


def _simulate(api, robot: str, **body) -> dict[str, np.ndarray]:
    body = {k: np.asarray(v).tolist() if isinstance(v, np.ndarray) else v for k, v in body.items()}
    r = api.post(f"/v1/robots/{robot}/simulate", json=body)
    assert r.status_code == 200, r.text
    return {k: np.asarray(x) for k, x in r.json().items()}


def _kinetic(model, q: np.ndarray, v: np.ndarray) -> float:
    return float(pin.computeKineticEnergy(model, model.createData(), q, v))


def test_torque_free_rk4_conserves_mechanical_energy(api, catalog_registry):
    """ur5 (no damping in its description) under gravity with τ = 0 for 1 s at dt = 1 ms:
    T + U is conserved to 1e-4 relative, while T itself changes a lot."""
    model = catalog_registry.catalog["ur5"].model
    assert not model.damping.any()
    q0 = np.array([0.3, -1.2, 1.0, -0.5, 0.8, 0.1])
    v0 = np.array([1.0, -0.5, 0.8, 1.5, -1.0, 2.0])
    out = _simulate(api, "ur5", q=q0, v=v0, dt=1e-3, steps=1000, integrator="rk4")
    E = out["mechanical_energy"]
    assert out["t"].shape == (1001,) and out["q"].shape == (1001, 6) and E.shape == (1001,)
    np.testing.assert_allclose(out["t"][[0, -1]], [0.0, 1.0], atol=1e-12)
    np.testing.assert_array_equal(out["q"][0], q0)
    np.testing.assert_array_equal(out["v"][0], v0)
    T = np.array([_kinetic(model, q, v) for q, v in zip(out["q"], out["v"], strict=True)])
    data = model.createData()
    np.testing.assert_allclose(
        E[[0, 500, 1000]],
        [
            pin.computeMechanicalEnergy(model, data, out["q"][i], out["v"][i])
            for i in (0, 500, 1000)
        ],
    )
    assert T.max() - T.min() > 0.5 * abs(E[0])  # energy really flows between T and U
    assert np.abs(E - E[0]).max() <= 1e-4 * abs(E[0])


def test_energy_includes_the_armature(api, catalog_registry):
    """talos has armature: the answer's energy is ½ vᵀ M v + U with M from CRBA."""
    model = catalog_registry.catalog["talos"].model
    assert model.armature.any()
    q, v, _ = random_state(model, np.random.default_rng(1))
    out = _simulate(api, "talos", q=q, v=v, dt=1e-3, steps=1)
    data = model.createData()
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    expected = 0.5 * v @ M @ v + pin.computePotentialEnergy(model, data, q)
    np.testing.assert_allclose(out["mechanical_energy"][0], expected, rtol=1e-12)


def test_rk4_is_fourth_order_on_a_free_flyer(api, catalog_registry):
    """solo12 falling and spinning for 0.2 s: halving dt divides the error by about 16."""
    model = catalog_registry.catalog["solo12"].model
    q0, v0, _ = random_state(model, np.random.default_rng(6))
    v0[3:6] = [2.0, -3.0, 4.0]  # a fast spin of the base

    def final(steps: int) -> tuple[np.ndarray, np.ndarray]:
        out = _simulate(api, "solo12", q=q0, v=v0, dt=0.2 / steps, steps=steps, integrator="rk4")
        return out["q"][-1], out["v"][-1]

    q_ref, v_ref = final(640)
    errors = []
    for steps in (20, 40):
        q, v = final(steps)
        errors.append(np.linalg.norm(pin.difference(model, q_ref, q)) + np.linalg.norm(v - v_ref))
    assert errors[0] / errors[1] > 12, errors


@pytest.mark.parametrize("integrator", ["semi-implicit-euler", "rk4"])
def test_quaternions_stay_unit(api, catalog_registry, integrator):
    model = catalog_registry.catalog["solo12"].model
    q0, v0, _ = random_state(model, np.random.default_rng(8))
    out = _simulate(api, "solo12", q=q0, v=v0, dt=1e-3, steps=1000, integrator=integrator)
    norms = np.linalg.norm(out["q"][:, 3:7], axis=1)
    np.testing.assert_allclose(norms, 1.0, rtol=0, atol=1e-12)
    assert np.abs(out["q"][-1, 3:7] - q0[3:7]).max() > 1e-2  # the base did rotate


def test_semi_implicit_euler_steps_with_a_torque_schedule(api, catalog_registry):
    """Step k uses τ_k: v ← v + dt a(q, v, τ_k), q ← q ⊕ dt v, re-done in process."""
    model = catalog_registry.catalog["solo12"].model
    rng = np.random.default_rng(2)
    q, v, _ = random_state(model, rng)
    dt, schedule = 2e-3, rng.normal(0, 2, (5, model.nv))
    out = _simulate(api, "solo12", q=q, v=v, dt=dt, steps=5, tau=schedule)
    data = model.createData()
    for k in range(5):
        v = v + dt * pin.aba(model, data, q, v, schedule[k])
        q = pin.normalize(model, pin.integrate(model, q, dt * v))
        np.testing.assert_allclose(out["v"][k + 1], v, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(out["q"][k + 1], q, rtol=1e-10, atol=1e-12)


def test_constant_torque_equals_a_constant_schedule(api):
    q, v, tau = [0.1] * 6, [0.2] * 6, [1.0, -2.0, 3.0, 0.5, 0.1, -0.3]
    constant = _simulate(api, "ur5", q=q, v=v, dt=1e-3, steps=20, tau=tau, integrator="rk4")
    schedule = _simulate(api, "ur5", q=q, v=v, dt=1e-3, steps=20, tau=[tau] * 20, integrator="rk4")
    free = _simulate(api, "ur5", q=q, v=v, dt=1e-3, steps=20, integrator="rk4")
    np.testing.assert_array_equal(constant["q"], schedule["q"])
    assert np.abs(constant["q"][-1] - free["q"][-1]).max() > 1e-6


def _gains(model, q: np.ndarray, kp: float, kd: float) -> tuple[list[float], list[float]]:
    """Joint gains scaled by the diagonal of M, so every joint has the same bandwidth."""
    M = np.diag(pin.crba(model, model.createData(), q))
    return (kp * M).tolist(), (kd * M).tolist()


@pytest.mark.parametrize("integrator", ["semi-implicit-euler", "rk4"])
def test_pd_with_gravity_compensation_converges_to_its_target(api, catalog_registry, integrator):
    model = catalog_registry.catalog["ur5"].model
    q0 = np.array([0.0, -1.0, 1.0, 0.0, 0.5, 0.0])
    target = q0 + np.array([0.4, -0.3, 0.5, 0.6, -0.4, 0.7])
    kp, kd = _gains(model, target, 100.0, 20.0)
    out = _simulate(
        api,
        "ur5",
        q=q0,
        v=np.zeros(6),
        dt=1e-3,
        steps=2000,
        integrator=integrator,
        controller={
            "type": "pd",
            "kp": kp,
            "kd": kd,
            "q_target": target.tolist(),
            "gravity_compensation": True,
        },
    )
    np.testing.assert_allclose(out["q"][-1], target, atol=1e-4)
    np.testing.assert_allclose(out["v"][-1], 0.0, atol=1e-3)
    assert np.abs(out["q"][100] - target).max() > 1e-2  # it did travel


def test_pd_without_gravity_compensation_settles_where_kp_error_balances_gravity(
    api, catalog_registry
):
    model = catalog_registry.catalog["ur5"].model
    target = np.array([0.2, -1.2, 1.3, -0.4, 0.5, 0.0])
    kp, kd = _gains(model, target, 100.0, 20.0)
    out = _simulate(
        api,
        "ur5",
        q=target,
        v=np.zeros(6),
        dt=1e-3,
        steps=3000,
        controller={"type": "pd", "kp": kp, "kd": kd, "q_target": target.tolist()},
    )
    q, v = out["q"][-1], out["v"][-1]
    g = pin.computeGeneralizedGravity(model, model.createData(), q)
    np.testing.assert_allclose(np.array(kp) * pin.difference(model, q, target), g, atol=1e-3)
    np.testing.assert_allclose(v, 0.0, atol=1e-4)
    assert np.abs(q - target).max() > 1e-3  # gravity pulled it off the target


def test_pd_error_is_taken_on_the_manifold(api, catalog_registry):
    """A continuous joint at θ = −π + 0.1 driven to π − 0.1 goes the short way, across ±π."""
    model = catalog_registry.catalog["double_pendulum_continuous"].model
    start, goal = -np.pi + 0.1, np.pi - 0.1
    q0 = np.array([np.cos(start), np.sin(start), 1.0, 0.0])
    target = np.array([np.cos(goal), np.sin(goal), 1.0, 0.0])
    kp, kd = _gains(model, target, 100.0, 20.0)
    out = _simulate(
        api,
        "double_pendulum_continuous",
        q=q0,
        v=np.zeros(2),
        dt=1e-3,
        steps=1500,
        integrator="rk4",
        controller={
            "type": "pd",
            "kp": kp,
            "kd": kd,
            "q_target": target.tolist(),
            "gravity_compensation": True,
        },
    )
    assert (out["q"][:, 0] < -0.9).all()  # cos θ stays near −1: it never swings through 0
    assert np.linalg.norm(pin.difference(model, out["q"][-1], target)) < 1e-3


def test_pd_drives_a_free_flyer_base_to_a_rotated_target(api, catalog_registry):
    model = catalog_registry.catalog["solo12"].model
    q0 = np.array(catalog_registry.catalog["solo12"].info()["default_configuration"])
    turn = np.zeros(model.nv)
    turn[:6] = [0.1, -0.2, 0.05, 0.3, -0.2, 0.6]
    target = pin.integrate(model, q0, turn)
    kp, kd = _gains(model, target, 100.0, 20.0)
    out = _simulate(
        api,
        "solo12",
        q=q0,
        v=np.zeros(model.nv),
        dt=1e-3,
        steps=2000,
        controller={
            "type": "pd",
            "kp": kp,
            "kd": kd,
            "q_target": target.tolist(),
            "gravity_compensation": True,
        },
    )
    assert np.linalg.norm(pin.difference(model, out["q"][-1], target)) < 1e-4


def test_batch_of_initial_states_equals_single_rollouts(api, catalog_registry):
    model = catalog_registry.catalog["panda"].model
    rng = np.random.default_rng(5)
    states = [random_state(model, rng)[:2] for _ in range(3)]
    qs, vs = (np.stack(x) for x in zip(*states, strict=True))
    batch = _simulate(api, "panda", q=qs, v=vs, dt=1e-3, steps=30, integrator="rk4")
    assert batch["t"].shape == (3, 31) and batch["q"].shape == (3, 31, model.nq)
    assert batch["v"].shape == (3, 31, model.nv) and batch["mechanical_energy"].shape == (3, 31)
    for i in range(3):
        single = _simulate(api, "panda", q=qs[i], v=vs[i], dt=1e-3, steps=30, integrator="rk4")
        for key in single:
            np.testing.assert_array_equal(batch[key][i], single[key])


def test_long_simulations_run_off_the_event_loop(api, monkeypatch):
    """The off-loop decision counts steps × nv (× 4 stages for rk4), not states × nv."""
    calls: list[str] = []
    original = routes.off_loop

    async def recording(request, fn, *args):
        if fn is dynamics.run:  # not the answer's encoding, which follows a large computation
            calls.append(args[1].name)
        return await original(request, fn, *args)

    monkeypatch.setattr(routes, "off_loop", recording)
    body = {"q": [0.0] * 6, "v": [0.0] * 6, "dt": 1e-3}
    _simulate(api, "ur5", **body, steps=300)  # 300 × 6 = 1800 ≤ 2000: inline
    assert calls == []
    _simulate(api, "ur5", **body, steps=100, integrator="rk4")  # 100 × 6 × 4 = 2400
    assert calls == ["simulate"]
    _simulate(api, "ur5", **body, steps=400)
    assert calls == ["simulate", "simulate"]


def test_steps_and_work_limits_are_configurable(small_app_factory):
    client = small_app_factory(catalog="ur5", max_simulation_steps=50, max_simulation_work=1000)
    body = {"q": [0.0] * 6, "v": [0.0] * 6, "dt": 1e-3}
    assert client.post("/v1/robots/ur5/simulate", json={**body, "steps": 40}).status_code == 200
    problem = assert_problem(
        client.post("/v1/robots/ur5/simulate", json={**body, "steps": 51}), 422, "validation_error"
    )
    assert "50" in problem["detail"] and "ROBODYN_MAX_SIMULATION_STEPS" in problem["detail"]
    problem = assert_problem(
        client.post("/v1/robots/ur5/simulate", json={**body, "steps": 50, "integrator": "rk4"}),
        422,
        "validation_error",
    )  # 50×6×4 = 1200
    assert "1000" in problem["detail"] and "ROBODYN_MAX_SIMULATION_WORK" in problem["detail"]
    batch = {"q": [[0.0] * 6] * 2, "v": [[0.0] * 6] * 2, "dt": 1e-3, "steps": 26}
    problem = assert_problem(
        client.post("/v1/robots/ur5/simulate", json=batch), 422, "validation_error"
    )  # 2 × 26 = 52 steps in all
    assert "2 states × 26 steps = 52" in problem["detail"]
    ok = client.post("/v1/robots/ur5/simulate", json={**batch, "steps": 25})
    assert ok.status_code == 200 and np.asarray(ok.json()["q"]).shape == (2, 26, 6)


Q6, V6 = [0.0] * 6, [0.0] * 6
PD = {"type": "pd", "kp": 10.0, "kd": 1.0, "q_target": Q6}


@pytest.mark.parametrize(
    "body, code",
    [
        ({"tau": [0.0] * 6, "controller": PD}, "validation_error"),
        ({"tau": [0.0] * 5}, "dimension_mismatch"),
        ({"tau": [[0.0] * 6] * 3}, "dimension_mismatch"),  # 3 rows for 10 steps
        ({"tau": [[0.0] * 5] * 10}, "dimension_mismatch"),
        ({"controller": {**PD, "q_target": [0.0] * 5}}, "dimension_mismatch"),
        ({"controller": {**PD, "kp": [1.0] * 5}}, "dimension_mismatch"),
        ({"controller": {**PD, "type": "pid"}}, "validation_error"),
        ({"controller": {**PD, "ki": 1.0}}, "validation_error"),
        ({"controller": {"type": "pd", "kp": 1.0, "q_target": Q6}}, "validation_error"),
        ({"integrator": "euler"}, "validation_error"),
        ({"dt": 0.0}, "validation_error"),
        ({"dt": -1e-3}, "validation_error"),
        ({"steps": 0}, "validation_error"),
        ({"steps": 1.5}, "validation_error"),
        ({"q": [0.0] * 5}, "dimension_mismatch"),
    ],
)
def test_simulate_errors(api, body, code):
    full = {"q": Q6, "v": V6, "dt": 1e-3, "steps": 10, **body}
    assert_problem(api.post("/v1/robots/ur5/simulate", json=full), 422, code)


def test_target_with_a_non_unit_quaternion_is_invalid(api, catalog_registry):
    model = catalog_registry.catalog["solo12"].model
    q = pin.neutral(model)
    target = q.copy()
    target[6] = 2.0
    body = {
        "q": q.tolist(),
        "v": [0.0] * model.nv,
        "dt": 1e-3,
        "steps": 3,
        "controller": {"type": "pd", "kp": 1.0, "kd": 1.0, "q_target": target.tolist()},
    }
    problem = assert_problem(
        api.post("/v1/robots/solo12/simulate", json=body), 422, "invalid_configuration"
    )
    assert "norm" in problem["detail"]


def test_a_diverging_simulation_is_a_non_finite_result(api):
    body = {
        "q": Q6,
        "v": V6,
        "dt": 0.1,
        "steps": 2000,
        "controller": {"type": "pd", "kp": 1e9, "kd": 0.0, "q_target": [1.0] * 6},
    }
    problem = assert_problem(
        api.post("/v1/robots/ur5/simulate", json=body), 422, "non_finite_result"
    )
    assert "dt" in problem["detail"]
