"""Every catalog robot, through HTTP, singly and in batch: mass-matrix-inverse, energy,
center-of-mass, jacobian and operational-space answer, agree with in-process Pinocchio and
with the service's own mass matrix. Adding a robot to robots/catalog.toml adds its tests."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.registry.catalog import catalog_entries
from tests.helpers import mass_matrix, random_state
from tests.operational_space_reference import RF, singular_ratio, task_matrix
from tests.service.dynamics.http_arrays import close, post

NAMES = [e.name for e in catalog_entries() if "urdf" in e.spec]
STATES = 2
DAMPING = 0.1


def _states(model, name):
    rng = np.random.default_rng(sum(map(ord, name)) + 1)
    q, v, _ = zip(*(random_state(model, rng) for _ in range(STATES)), strict=True)
    return np.array(q), np.array(v)


def _end_frame(model) -> str:
    """The link moved by the last joint of the model."""
    last = model.njoints - 1
    return next(
        f.name for f in model.frames if f.parentJoint == last and f.type == pin.FrameType.BODY
    )


def _single_equals_batch(api, name, quantity, batch, **inputs):
    """Each state sent alone gives the batch's row, bit for bit."""
    for i in range(STATES):
        single = post(
            api, name, quantity, **{k: (x[i] if k in ("q", "v") else x) for k, x in inputs.items()}
        )
        assert set(single) == set(batch)
        for key, value in single.items():
            np.testing.assert_array_equal(value, batch[key][i], err_msg=f"{quantity} {key}")


@pytest.mark.parametrize("name", NAMES)
def test_lagrangian_jacobian_and_operational_space_on_every_catalog_robot(
    api, catalog_registry, name
):
    robot = catalog_registry.catalog[name]
    model = robot.model
    q, v = _states(model, name)
    massless = any(w["code"] == "massless_subtree" for w in robot.warnings)
    M = post(api, name, "mass-matrix", q=q)["mass_matrix"]

    # mass-matrix-inverse
    if massless:  # M is singular: no inverse, a clear 422 (romeo's fingers carry no mass)
        body = post(api, name, "mass-matrix-inverse", 422, q=q)
        assert body["code"] == "non_finite_result"
    else:
        got = post(api, name, "mass-matrix-inverse", q=q)
        assert got["mass_matrix_inverse"].shape == (STATES, model.nv, model.nv)
        _single_equals_batch(api, name, "mass-matrix-inverse", got, q=q)
        for i in range(STATES):
            cond = np.linalg.cond(M[i])
            close(got["mass_matrix_inverse"][i] @ M[i], np.eye(model.nv), 1e-13 * cond)
            close(
                got["mass_matrix_inverse"][i], np.linalg.inv(mass_matrix(model, q[i])), 1e-13 * cond
            )

    # energy
    e = post(api, name, "energy", q=q, v=v)
    assert all(x.shape == (STATES,) for x in e.values())
    _single_equals_batch(api, name, "energy", e, q=q, v=v)
    close(e["kinetic_energy"], 0.5 * np.einsum("ni,nij,nj->n", v, M, v), 1e-12)
    close(e["mechanical_energy"], e["kinetic_energy"] + e["potential_energy"], 1e-14)
    data = model.createData()
    close(e["potential_energy"], [pin.computePotentialEnergy(model, data, x) for x in q], 1e-12)

    # center-of-mass
    com = post(api, name, "center-of-mass", q=q, v=v)
    assert com["jacobian"].shape == (STATES, 3, model.nv)
    _single_equals_batch(api, name, "center-of-mass", com, q=q, v=v)
    for i in range(STATES):
        close(com["position"][i], pin.centerOfMass(model, data, q[i]), 1e-12)
        close(com["velocity"][i], pin.jacobianCenterOfMass(model, data, q[i]) @ v[i], 1e-12)

    # jacobian (and its time variation) of the link moved by the last joint
    frame = _end_frame(model)
    fid = model.getFrameId(frame)
    jac = post(api, name, "jacobian", q=q, v=v, frame=frame)
    assert jac["jacobian"].shape == jac["jacobian_time_variation"].shape == (STATES, 6, model.nv)
    _single_equals_batch(api, name, "jacobian", jac, q=q, v=v, frame=frame)
    for i in range(STATES):
        pin.computeJointJacobiansTimeVariation(model, data, q[i], v[i])
        pin.updateFramePlacements(model, data)
        close(
            jac["jacobian"][i],
            pin.getFrameJacobian(model, data, fid, RF["local_world_aligned"]),
            1e-12,
        )
        close(
            jac["jacobian_time_variation"][i],
            pin.getFrameJacobianTimeVariation(model, data, fid, RF["local_world_aligned"]),
            1e-12,
        )
    assert jac["jacobian"][:, :, :].any()  # the last joint moves its link

    # operational-space of that link's position (3 rows): undamped where it is not singular,
    # a 422 where it clearly is; damped always
    if massless:
        body = post(
            api, name, "operational-space", 422, q=q, frame=frame, task="linear", damping=DAMPING
        )
        assert body["code"] == "non_finite_result"
        return
    J = jac["jacobian"][:, :3]
    ratios = [singular_ratio(mass_matrix(model, q[i]), J[i]) for i in range(STATES)]
    r = api.post(
        f"/v1/robots/{name}/operational-space",
        json={"q": q.tolist(), "v": v.tolist(), "frame": frame, "task": "linear"},
    )
    if min(ratios) > 1e-6:
        assert r.status_code == 200, r.text
        got = {k: np.asarray(x) for k, x in r.json().items()}
        for i in range(STATES):
            rtol = 1e-9 * np.linalg.cond(M[i]) / ratios[i]
            close(got["inertia"][i] @ task_matrix(M[i], J[i]), np.eye(3), rtol)
            close(J[i] @ got["dynamically_consistent_inverse"][i], np.eye(3), rtol)
    elif min(ratios) < 1e-10:
        assert r.status_code == 422 and r.json()["code"] == "singular_configuration", r.text
    damped = post(
        api, name, "operational-space", q=q, v=v, frame=frame, task="linear", damping=DAMPING
    )
    assert damped["inertia"].shape == (STATES, 3, 3)
    assert damped["coriolis"].shape == damped["gravity"].shape == (STATES, 3)
    _single_equals_batch(
        api,
        name,
        "operational-space",
        damped,
        q=q,
        v=v,
        frame=frame,
        task="linear",
        damping=DAMPING,
    )
    for i in range(STATES):
        A = task_matrix(M[i], J[i]) + DAMPING**2 * np.eye(3)
        close(damped["inertia"][i] @ A, np.eye(3), 1e-9 * np.linalg.cond(M[i]))
        close(
            damped["dynamically_consistent_inverse"][i],
            np.linalg.solve(M[i], J[i].T) @ damped["inertia"][i],
            1e-9 * np.linalg.cond(M[i]),
        )
