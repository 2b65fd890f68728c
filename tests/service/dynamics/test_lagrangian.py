"""M⁻¹, energies and the centre of mass through HTTP, against the service's own M, g, forward
dynamics and in-process Pinocchio.

The power identity used: with M a + C v + g = τ (τ the applied generalized force; gravity is
not part of it, its work is the change of U),
    dT/dt = vᵀ M a + ½ vᵀ Ṁ v = vᵀ M a + vᵀ C v     (Ṁ = C + Cᵀ)
    dU/dt = gᵀ v                                     (g = ∂U/∂q)
so d(T + U)/dt = vᵀ (M a + C v + g) = vᵀ τ.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from tests.helpers import mass_matrix, random_state
from tests.service.dynamics.http_arrays import close, post

ROBOTS = ["ur5", "talos", "solo12", "double_pendulum_continuous", "planar_arm", "cube_pendulum"]


def _state(catalog_registry, name, seed=0):
    model = catalog_registry.catalog[name].model
    q, v, a = random_state(model, np.random.default_rng(seed))
    return model, q, v, a


@pytest.mark.parametrize("name", ROBOTS)
def test_mass_matrix_inverse(api, catalog_registry, name):
    model, q, _, _ = _state(catalog_registry, name)
    Minv = post(api, name, "mass-matrix-inverse", q=q)["mass_matrix_inverse"]
    M = post(api, name, "mass-matrix", q=q)["mass_matrix"]
    np.testing.assert_array_equal(Minv, Minv.T)
    cond = np.linalg.cond(M)
    close(Minv @ M, np.eye(model.nv), 1e-13 * cond)
    close(Minv, np.linalg.inv(mass_matrix(model, q)), 1e-13 * cond)
    assert np.linalg.eigvalsh(Minv)[0] > 0


@pytest.mark.parametrize("name", ROBOTS)
def test_energies(api, catalog_registry, name):
    model, q, v, _ = _state(catalog_registry, name, seed=1)
    e = post(api, name, "energy", q=q, v=v)
    assert all(x.shape == () for x in e.values())
    M = post(api, name, "mass-matrix", q=q)["mass_matrix"]
    close(e["kinetic_energy"], 0.5 * v @ M @ v, 1e-12)
    close(e["mechanical_energy"], e["kinetic_energy"] + e["potential_energy"], 1e-15)
    # U = −m g₀ᵀ c: the centre of mass at height z gives m · 9.81 · z
    com = post(api, name, "center-of-mass", q=q)["position"]
    mass = api.get(f"/v1/robots/{name}").json()["total_mass"]
    close(e["potential_energy"], mass * 9.81 * com[2], 1e-12)
    # g = ∂U/∂q, by central differences of U along a random direction
    direction, h = np.random.default_rng(2).normal(size=model.nv), 1e-6
    qs = np.stack([pin.integrate(model, q, h * direction), pin.integrate(model, q, -h * direction)])
    U = post(api, name, "energy", q=qs, v=np.zeros((2, model.nv)))["potential_energy"]
    g = post(api, name, "gravity", q=q)["gravity"]
    np.testing.assert_allclose(
        (U[0] - U[1]) / (2 * h), g @ direction, atol=1e-6 * max(1.0, np.abs(g).max())
    )


def test_power_identity_along_a_simulated_motion(api, catalog_registry):
    """Integrate ur5's forward dynamics (from the service) under a constant torque with RK4:
    the mechanical energy changes by the work of τ, ∫ vᵀ τ dt = τᵀ (q(t) − q(0)) (revolute
    joints), and stays constant without torque."""
    model = catalog_registry.catalog["ur5"].model
    q0, v0, _ = random_state(model, np.random.default_rng(4))
    dt, steps = 2e-3, 100

    def accel(q, v, tau):
        return post(api, "ur5", "forward-dynamics", q=q, v=v, tau=tau)["a"]

    for tau in (np.zeros(6), np.array([3.0, -8.0, 4.0, 1.0, -0.5, 0.2])):
        q, v = q0.copy(), v0.copy()
        for _ in range(steps):
            k1q, k1v = v, accel(q, v, tau)
            k2q, k2v = v + dt / 2 * k1v, accel(q + dt / 2 * k1q, v + dt / 2 * k1v, tau)
            k3q, k3v = v + dt / 2 * k2v, accel(q + dt / 2 * k2q, v + dt / 2 * k2v, tau)
            k4q, k4v = v + dt * k3v, accel(q + dt * k3q, v + dt * k3v, tau)
            q = q + dt / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
            v = v + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        E = post(api, "ur5", "energy", q=np.stack([q0, q]), v=np.stack([v0, v]))
        work = tau @ (q - q0)
        change = E["mechanical_energy"][1] - E["mechanical_energy"][0]
        assert abs(E["kinetic_energy"][1] - E["kinetic_energy"][0]) > 1e-3  # it did move
        np.testing.assert_allclose(
            change, work, atol=1e-8 * max(1.0, abs(E["potential_energy"][0]))
        )


@pytest.mark.parametrize("name", ROBOTS)
def test_center_of_mass(api, catalog_registry, name):
    model, q, v, _ = _state(catalog_registry, name, seed=5)
    got = post(api, name, "center-of-mass", q=q, v=v)
    assert got["position"].shape == got["velocity"].shape == (3,)
    assert got["jacobian"].shape == (3, model.nv)
    data = model.createData()
    close(got["position"], pin.centerOfMass(model, data, q), 1e-12)
    close(got["jacobian"], pin.jacobianCenterOfMass(model, data, q), 1e-12)
    close(got["velocity"], got["jacobian"] @ v, 1e-12)
    # ċ by central differences of the position along v
    h = 1e-6
    qs = np.stack([pin.integrate(model, q, h * v), pin.integrate(model, q, -h * v)])
    c = post(api, name, "center-of-mass", q=qs)["position"]
    np.testing.assert_allclose(got["velocity"], (c[0] - c[1]) / (2 * h), atol=1e-7)
    # the mass-weighted mean of the bodies' centres of mass (GET .../inertias, joint frames)
    bodies = api.get(f"/v1/robots/{name}/inertias").json()["bodies"]
    pin.forwardKinematics(model, data, q)
    weighted = sum(
        b["mass"] * data.oMi[model.getJointId(b["joint"])].act(np.asarray(b["center_of_mass"]))
        for b in bodies
    )
    close(got["position"], weighted / sum(b["mass"] for b in bodies), 1e-12)
    without_v = post(api, name, "center-of-mass", q=q)
    assert set(without_v) == {"position", "jacobian"}


def _unaligned_arm_with_armature():
    """Two bodies: a revolute joint about the unaligned axis (1, 1, 0)/√2 (Pinocchio's
    RevoluteUnaligned), then one about z; both with armature (a motor's rotor)."""
    from service.registry.robot import Robot

    model = pin.Model()
    axis = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    j1 = model.addJoint(0, pin.JointModelRevoluteUnaligned(axis), pin.SE3.Identity(), "j1")
    model.appendBodyToJoint(
        j1, pin.Inertia.FromBox(2.0, 0.1, 0.2, 0.3), pin.SE3(np.eye(3), np.array([0.1, 0.0, 0.2]))
    )
    j2 = model.addJoint(j1, pin.JointModelRZ(), pin.SE3(np.eye(3), np.array([0.5, 0.0, 0.0])), "j2")
    model.appendBodyToJoint(j2, pin.Inertia.FromBox(1.0, 0.1, 0.2, 0.3), pin.SE3.Identity())
    model.armature[:] = [0.3, 0.2]
    return Robot(id="unaligned", name="unaligned", source="upload", root_joint="fixed", model=model)


def test_kinetic_energy_includes_the_armature_of_an_unaligned_revolute_joint():
    """T = ½ vᵀ M v with M's armature: Pinocchio's computeKineticEnergy alone leaves out the
    unaligned joint's ½ · 0.3 · v₁²."""
    from service.api.quantities import SPECS
    from service.dynamics import run
    from service.states import States

    robot = _unaligned_arm_with_armature()
    rng = np.random.default_rng(7)
    q, v = rng.uniform(-1.0, 1.0, (2, 5, 2))
    T = run(robot, SPECS["energy"].quantity, States({"q": q, "v": v}, True), {})["kinetic_energy"]
    expected = [0.5 * v[i] @ mass_matrix(robot.model, q[i]) @ v[i] for i in range(5)]
    np.testing.assert_allclose(T, expected, rtol=1e-14, atol=1e-14)


def test_a_free_motion_keeps_its_mechanical_energy_with_armature():
    """With no torque the mechanical energy T + U is conserved (RK4, small steps): it is not
    when T leaves out part of the armature that the dynamics (ABA) has."""
    from service.api.quantities import SPECS
    from service.dynamics import run
    from service.states import States

    robot = _unaligned_arm_with_armature()
    s = States({"q": np.array([[0.3, -0.4]]), "v": np.array([[1.2, -0.7]])}, False)
    out = run(
        robot,
        SPECS["simulate"].quantity,
        s,
        {
            "dt": 1e-3,
            "steps": 2000,
            "integrator": "rk4",
            "max_simulation_steps": 10_000,
            "max_simulation_work": 10**9,
        },
    )
    energy = out["mechanical_energy"]
    assert np.ptp(energy) < 1e-9 * max(1.0, abs(energy[0]))
