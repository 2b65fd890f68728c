"""External wrenches on inverse and forward dynamics: a wrench w at a frame changes inverse
dynamics by −Jᵀ w, with J the frame Jacobian from in-process Pinocchio in the same reference
frame; forward dynamics inverts inverse dynamics under the same wrenches."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

from tests.helpers import random_state
from tests.service.api.problems.test_errors import assert_problem

FRAMES = {"ur5": "tool0", "panda": "panda_hand_tcp", "solo12": "FL_FOOT", "talos": "imu_link"}
REFERENCE = {"world": pin.WORLD, "local": pin.LOCAL, "local_world_aligned": pin.LOCAL_WORLD_ALIGNED}


def _post(api, robot: str, path: str, **body) -> np.ndarray:
    body = {k: np.asarray(v).tolist() if isinstance(v, np.ndarray) else v for k, v in body.items()}
    r = api.post(f"/v1/robots/{robot}/{path}", json=body)
    assert r.status_code == 200, r.text
    (value,) = r.json().values()
    return np.asarray(value)


def _jacobian(model, q: np.ndarray, frame: str, reference: str) -> np.ndarray:
    data = model.createData()
    return pin.computeFrameJacobian(
        model, data, q, model.getFrameId(frame), REFERENCE[reference]
    ).copy()


@pytest.mark.parametrize("reference", list(REFERENCE))
@pytest.mark.parametrize("robot", list(FRAMES))
def test_wrench_changes_inverse_dynamics_by_minus_jacobian_transpose(
    api, catalog_registry, robot, reference
):
    model = catalog_registry.catalog[robot].model
    rng = np.random.default_rng(31)
    q, v, a = random_state(model, rng)
    w = rng.normal(0, 10, 6)
    force = {"frame": FRAMES[robot], "wrench": w.tolist(), "reference_frame": reference}
    free = _post(api, robot, "inverse-dynamics", q=q, v=v, a=a)
    loaded = _post(api, robot, "inverse-dynamics", q=q, v=v, a=a, external_forces=[force])
    J = _jacobian(model, q, FRAMES[robot], reference)
    np.testing.assert_allclose(
        loaded - free, -J.T @ w, rtol=0, atol=1e-9 * (1 + np.abs(free).max())
    )
    # and forward dynamics under the same wrench gives back a
    back = _post(api, robot, "forward-dynamics", q=q, v=v, tau=loaded, external_forces=[force])
    np.testing.assert_allclose(back, a, rtol=0, atol=1e-7)


def test_default_reference_frame_is_local_world_aligned(api, catalog_registry):
    model = catalog_registry.catalog["ur5"].model
    q, v, a = random_state(model, np.random.default_rng(2))
    w = [5.0, -3.0, 2.0, 0.5, 0.1, -0.2]
    plain = _post(
        api,
        "ur5",
        "inverse-dynamics",
        q=q,
        v=v,
        a=a,
        external_forces=[{"frame": "tool0", "wrench": w}],
    )
    aligned = _post(
        api,
        "ur5",
        "inverse-dynamics",
        q=q,
        v=v,
        a=a,
        external_forces=[{"frame": "tool0", "wrench": w, "reference_frame": "local_world_aligned"}],
    )
    world = _post(
        api,
        "ur5",
        "inverse-dynamics",
        q=q,
        v=v,
        a=a,
        external_forces=[{"frame": "tool0", "wrench": w, "reference_frame": "world"}],
    )
    np.testing.assert_array_equal(plain, aligned)
    assert np.abs(plain - world).max() > 1e-3  # the choice matters: torque about another point


def test_forward_dynamics_with_wrenches_equals_the_equation_of_motion(api, catalog_registry):
    """a = M⁻¹ (τ − h + Σ Jᵀ w), two wrenches on two feet of a free-flyer robot."""
    model = catalog_registry.catalog["solo12"].model
    rng = np.random.default_rng(9)
    q, v, tau = random_state(model, rng)
    forces = [
        {"frame": f, "wrench": rng.normal(0, 5, 6).tolist(), "reference_frame": ref}
        for f, ref in (("FL_FOOT", "world"), ("HR_FOOT", "local"))
    ]
    got = _post(api, "solo12", "forward-dynamics", q=q, v=v, tau=tau, external_forces=forces)
    data = model.createData()
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    h = pin.nonLinearEffects(model, data, q, v).copy()
    generalized = sum(
        _jacobian(model, q, f["frame"], f["reference_frame"]).T @ f["wrench"] for f in forces
    )
    np.testing.assert_allclose(got, np.linalg.solve(M, tau - h + generalized), rtol=1e-8, atol=1e-8)


def test_batch_with_wrenches_per_state_and_shared(api, catalog_registry):
    """A wrench of 6 numbers applies to every state, one of [N][6] to each state; a batch
    large enough for the parallel path still goes through the serial one with the forces."""
    model = catalog_registry.catalog["ur5"].model
    rng = np.random.default_rng(10)
    n = 80  # above the parallel threshold (64)
    states = [random_state(model, rng) for _ in range(n)]
    qs, vs, as_ = (np.stack(x) for x in zip(*states, strict=True))
    rows = rng.normal(0, 5, (n, 6))
    shared = [1.0, 2.0, 3.0, 0.1, 0.2, 0.3]
    forces = [
        {"frame": "tool0", "wrench": rows.tolist()},
        {"frame": "wrist_2_link", "wrench": shared, "reference_frame": "local"},
    ]
    batch = _post(api, "ur5", "inverse-dynamics", q=qs, v=vs, a=as_, external_forces=forces)
    for i in (0, 41, n - 1):
        one = [{"frame": "tool0", "wrench": rows[i].tolist()}, forces[1]]
        single = _post(
            api, "ur5", "inverse-dynamics", q=qs[i], v=vs[i], a=as_[i], external_forces=one
        )
        np.testing.assert_array_equal(batch[i], single)
        expected = (
            pin.rnea(model, model.createData(), qs[i], vs[i], as_[i])
            - _jacobian(model, qs[i], "tool0", "local_world_aligned").T @ rows[i]
            - _jacobian(model, qs[i], "wrist_2_link", "local").T @ np.array(shared)
        )
        np.testing.assert_allclose(single, expected, rtol=0, atol=1e-9)


def test_unknown_frame_is_422_pointing_to_the_frames(api):
    body = {
        "q": [0.0] * 6,
        "v": [0.0] * 6,
        "a": [0.0] * 6,
        "external_forces": [
            {"frame": "tool0", "wrench": [0.0] * 6},
            {"frame": "no_such_frame", "wrench": [0.0] * 6},
        ],
    }
    problem = assert_problem(
        api.post("/v1/robots/ur5/inverse-dynamics", json=body), 422, "unknown_frame"
    )
    assert "external_forces[1].frame" in problem["detail"]
    assert "`frames` of GET /v1/robots/ur5" in problem["detail"]
    assert "no frame 'no_such_frame'" in problem["detail"]  # short printable names are shown
    body["tau"] = body.pop("a")
    assert_problem(api.post("/v1/robots/ur5/forward-dynamics", json=body), 422, "unknown_frame")


@pytest.mark.parametrize(
    "force",
    [
        {"frame": "tool0", "wrench": [0.0] * 5},
        {"frame": "tool0", "wrench": [0.0] * 6, "reference_frame": "body"},
        {"frame": "tool0", "wrench": [0.0, 0.0, 0.0, 0.0, 0.0, float("nan")]},
        {"frame": "tool0"},
        {"frame": 3, "wrench": [0.0] * 6},
        {"frame": "tool0", "wrench": [0.0] * 6, "point": [0, 0, 0]},
    ],
)
def test_malformed_forces_are_validation_errors(api, force):
    body = {"q": [0.0] * 6, "v": [0.0] * 6, "a": [0.0] * 6, "external_forces": [force]}
    r = api.post(
        "/v1/robots/ur5/inverse-dynamics",
        content=json.dumps(body),  # NaN as is
        headers={"content-type": "application/json"},
    )
    assert_problem(r, 422, "validation_error")


def test_wrench_rows_must_match_the_batch(api):
    single = {
        "q": [0.0] * 6,
        "v": [0.0] * 6,
        "a": [0.0] * 6,
        "external_forces": [{"frame": "tool0", "wrench": [[0.0] * 6] * 2}],
    }
    assert_problem(
        api.post("/v1/robots/ur5/inverse-dynamics", json=single), 422, "dimension_mismatch"
    )
    batch = {
        "q": [[0.0] * 6] * 3,
        "v": [[0.0] * 6] * 3,
        "a": [[0.0] * 6] * 3,
        "external_forces": [{"frame": "tool0", "wrench": [[0.0] * 6] * 2}],
    }
    body = assert_problem(
        api.post("/v1/robots/ur5/inverse-dynamics", json=batch), 422, "dimension_mismatch"
    )
    assert "3 states" in body["detail"]
