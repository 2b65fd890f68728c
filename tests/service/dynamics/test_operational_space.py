"""Operational-space dynamics and frame Jacobians through HTTP: the service's Λ, J̄, μ, p equal
the formulas evaluated with numpy from the service's own M, J, J̇, C, g and in-process
Pinocchio; Khatib's task-space equation of motion holds; singular and damped cases."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.api.encoding import binary
from tests.helpers import mass_matrix, random_configuration
from tests.operational_space_reference import (
    ROWS,
    SINGULAR_RCOND,
    khatib_formulas,
    pinocchio_operational_space,
    singular_ratio,
    task_matrix,
)
from tests.service.dynamics.http_arrays import close, post

# (robot, frame, task, reference frame): fixed and floating bases, every task and frame kind.
CASES = [
    ("ur5", "tool0", "full", "local_world_aligned"),
    ("ur5", "tool0", "full", "local"),
    ("ur5", "wrist_3_link", "full", "world"),
    ("panda", "panda_hand_tcp", "full", "local_world_aligned"),
    ("panda", "panda_hand", "angular", "local"),
    ("talos", "arm_left_7_link", "full", "local_world_aligned"),
    ("solo12", "FL_FOOT", "linear", "world"),
    ("planar_arm", "tip", "linear", "local_world_aligned"),  # 2 joints: needs damping
]
UR5_Q = np.array([0.3, -1.0, 1.2, -0.7, 1.1, 0.4])  # well away from singularities


def _state(catalog_registry, name: str, seed: int):
    model = catalog_registry.catalog[name].model
    rng = np.random.default_rng(seed)
    q = UR5_Q.copy() if name == "ur5" else random_configuration(model, rng)
    return model, q, rng.normal(size=model.nv)


def _service_terms(api, name, q, v, frame, reference_frame):
    """M, J, J̇, C, g from the service's own endpoints."""
    M = post(api, name, "mass-matrix", q=q)["mass_matrix"]
    jac = post(api, name, "jacobian", q=q, v=v, frame=frame, reference_frame=reference_frame)
    C = post(api, name, "coriolis", q=q, v=v)["coriolis_matrix"]
    g = post(api, name, "gravity", q=q)["gravity"]
    return M, jac["jacobian"], jac["jacobian_time_variation"], C, g


@pytest.mark.parametrize(("name", "frame", "task", "reference_frame"), CASES)
def test_operational_space_equals_the_formulas(
    api, catalog_registry, name, frame, task, reference_frame
):
    model, q, v = _state(catalog_registry, name, seed=len(frame))
    M, J6, dJ6, C, g = _service_terms(api, name, q, v, frame, reference_frame)
    J, dJ = J6[ROWS[task]], dJ6[ROWS[task]]
    ratio = singular_ratio(M, J)
    damping = 0.0 if ratio > 1e-6 else 0.05
    if damping:
        assert name == "planar_arm"  # the other cases were chosen away from singularities
    got = post(
        api,
        name,
        "operational-space",
        q=q,
        v=v,
        frame=frame,
        task=task,
        reference_frame=reference_frame,
        damping=damping,
    )
    k = J.shape[0]
    assert got["inertia"].shape == (k, k) and got["jacobian"].shape == (k, model.nv)
    assert got["dynamically_consistent_inverse"].shape == (model.nv, k)
    assert got["gravity"].shape == got["coriolis"].shape == (k,)

    cond = 1.0 / max(ratio, 1e-16) if not damping else 1.0
    rtol = 1e-9 * max(1.0, np.linalg.cond(M)) * cond
    # The formulas with numpy from the service's own M, J, J̇, C, g ...
    for key, want in khatib_formulas(M, J, dJ, C, g, v, damping).items():
        close(got[key], want, rtol)
    # ... and from in-process Pinocchio.
    ref = pinocchio_operational_space(model, q, v, frame, reference_frame, task, damping)
    for key, want in ref.items():
        close(got[key], want, rtol)

    Lambda, Jbar = got["inertia"], got["dynamically_consistent_inverse"]
    np.testing.assert_allclose(Lambda, Lambda.T, atol=1e-12 * np.abs(Lambda).max())
    assert np.linalg.eigvalsh(Lambda)[0] > 0
    A = task_matrix(M, J) + damping**2 * np.eye(k)
    close(Lambda @ A, np.eye(k), rtol)  # Λ (J M⁻¹ Jᵀ + λ² I) = I
    if not damping:
        close(J @ Jbar, np.eye(k), rtol)  # J̄ is a generalized inverse of J
        close(Jbar, np.linalg.solve(M, J.T) @ Lambda, rtol)


@pytest.mark.parametrize(
    ("name", "frame", "task", "reference_frame"), [c for c in CASES if c[0] != "planar_arm"]
)
def test_task_space_equation_of_motion(api, catalog_registry, name, frame, task, reference_frame):
    """Λ ẍ + μ + p = F for ẍ = J a + J̇ v, with a the service's forward dynamics under the joint
    torques τ = Jᵀ F of a random task force F."""
    _, q, v = _state(catalog_registry, name, seed=3)
    os = post(
        api,
        name,
        "operational-space",
        q=q,
        v=v,
        frame=frame,
        task=task,
        reference_frame=reference_frame,
    )
    jac = post(api, name, "jacobian", q=q, v=v, frame=frame, reference_frame=reference_frame)
    J, dJ = jac["jacobian"][ROWS[task]], jac["jacobian_time_variation"][ROWS[task]]
    F = np.random.default_rng(5).normal(size=J.shape[0]) * 10
    a = post(api, name, "forward-dynamics", q=q, v=v, tau=J.T @ F)["a"]
    x_dd = J @ a + dJ @ v
    lhs = os["inertia"] @ x_dd + os["coriolis"] + os["gravity"]
    M = post(api, name, "mass-matrix", q=q)["mass_matrix"]
    close(lhs, F, 1e-8 * np.linalg.cond(M) / singular_ratio(M, J))


@pytest.mark.parametrize("reference_frame", ["world", "local", "local_world_aligned"])
@pytest.mark.parametrize(
    "name, frame", [("ur5", "tool0"), ("solo12", "FR_FOOT"), ("talos", "gripper_left_base_link")]
)
def test_jacobian_time_variation_is_the_derivative_of_the_jacobian(
    api, catalog_registry, name, frame, reference_frame
):
    model, q, v = _state(catalog_registry, name, seed=11)
    got = post(api, name, "jacobian", q=q, v=v, frame=frame, reference_frame=reference_frame)
    assert got["jacobian"].shape == got["jacobian_time_variation"].shape == (6, model.nv)
    h = 1e-6
    qs = np.stack([pin.integrate(model, q, v * h), pin.integrate(model, q, -v * h)])
    J_pm = post(api, name, "jacobian", q=qs, frame=frame, reference_frame=reference_frame)[
        "jacobian"
    ]
    np.testing.assert_allclose(
        got["jacobian_time_variation"],
        (J_pm[0] - J_pm[1]) / (2 * h),
        atol=1e-6 * max(1.0, np.abs(got["jacobian"]).max()),
    )
    without_v = post(api, name, "jacobian", q=q, frame=frame, reference_frame=reference_frame)
    assert set(without_v) == {"jacobian"}
    close(without_v["jacobian"], got["jacobian"], 1e-12)


def test_reference_frames_are_pinocchios(api, catalog_registry):
    """J in world and local_world_aligned follow from J local by the frame's placement (R, p):
    J_lwa = diag(R, R) J_local, J_world = [[R, p̂ R], [0, R]] J_local; linear rows first."""
    model = catalog_registry.catalog["ur5"].model
    data = model.createData()
    q = UR5_Q
    pin.framesForwardKinematics(model, data, q)
    placement = data.oMf[model.getFrameId("tool0")]
    R, p = placement.rotation, placement.translation
    J = {
        rf: post(api, "ur5", "jacobian", q=q, frame="tool0", reference_frame=rf)["jacobian"]
        for rf in ("world", "local", "local_world_aligned")
    }
    local = J["local"]
    close(J["local_world_aligned"], np.vstack([R @ local[:3], R @ local[3:]]), 1e-12)
    close(
        J["world"], np.vstack([R @ local[:3] + pin.skew(p) @ R @ local[3:], R @ local[3:]]), 1e-12
    )
    # the default is local_world_aligned; its linear rows give the velocity of the frame origin
    default = post(api, "ur5", "jacobian", q=q, frame="tool0")["jacobian"]
    np.testing.assert_array_equal(default, J["local_world_aligned"])
    v, h = np.random.default_rng(2).normal(size=6), 1e-6
    positions = []
    for qq in (q + h * v, q - h * v):
        pin.framesForwardKinematics(model, data, qq)
        positions.append(data.oMf[model.getFrameId("tool0")].translation.copy())
    close(default[:3] @ v, (positions[0] - positions[1]) / (2 * h), 1e-7)


def test_task_rows(api):
    full = post(api, "ur5", "operational-space", q=UR5_Q, frame="tool0")
    M = post(api, "ur5", "mass-matrix", q=UR5_Q)["mass_matrix"]
    A = task_matrix(M, full["jacobian"])
    for task, rows in (("linear", slice(0, 3)), ("angular", slice(3, 6))):
        part = post(api, "ur5", "operational-space", q=UR5_Q, frame="tool0", task=task)
        np.testing.assert_array_equal(part["jacobian"], full["jacobian"][rows])
        close(part["inertia"], np.linalg.inv(A[rows, rows]), 1e-9)
        # a 3-row task's inertia is not the block of the 6-row one (coupling through M)
        assert not np.allclose(part["inertia"], full["inertia"][rows, rows], rtol=1e-3)


# -- singular and damped configurations ---------------------------------------------------


def test_straight_ur5_is_singular_and_says_how_close(api, catalog_registry):
    q = np.zeros(6)  # shoulder, elbow and wrist singular: the arm is stretched out
    body = post(api, "ur5", "operational-space", 422, q=q, frame="tool0")
    assert body["code"] == "singular_configuration"
    detail = body["detail"]
    assert "smallest singular value" in detail and "condition number" in detail
    assert '"damping"' in detail and "1e-08" in detail and "tool0" in detail
    assert body["smallest_singular_value"] <= SINGULAR_RCOND * body["largest_singular_value"]
    M = mass_matrix(catalog_registry.catalog["ur5"].model, q)
    J = post(api, "ur5", "jacobian", q=q, frame="tool0")["jacobian"]
    np.testing.assert_allclose(
        body["largest_singular_value"], np.linalg.eigvalsh(task_matrix(M, J))[-1], rtol=1e-9
    )


@pytest.mark.parametrize("elbow", [0.5, 1e-1, 1e-5, 1e-7])
def test_singularity_threshold_is_relative_to_the_largest_singular_value(
    api, catalog_registry, elbow
):
    """Only the elbow approaches its singularity: σ_min/σ_max of J M⁻¹ Jᵀ falls like elbow²,
    and the answer switches to 422 below the documented ratio 1e-8."""
    q = np.array([0.2, -1.0, elbow, -0.8, 1.2, 0.3])
    M = mass_matrix(catalog_registry.catalog["ur5"].model, q)
    J = post(api, "ur5", "jacobian", q=q, frame="tool0")["jacobian"]
    ratio = singular_ratio(M, J)
    assert not 1e-2 * SINGULAR_RCOND < ratio < 1e2 * SINGULAR_RCOND  # clear of the threshold
    r = api.post("/v1/robots/ur5/operational-space", json={"q": q.tolist(), "frame": "tool0"})
    if ratio > SINGULAR_RCOND:
        assert r.status_code == 200, r.text
        Lambda = np.asarray(r.json()["inertia"])
        close(Lambda @ task_matrix(M, J), np.eye(6), 1e-10 / ratio)
    else:
        assert r.status_code == 422 and r.json()["code"] == "singular_configuration", r.text


def test_damping_regularizes_a_singular_configuration(api, catalog_registry):
    q, lam = np.zeros(6), 0.05
    M = mass_matrix(catalog_registry.catalog["ur5"].model, q)
    got = post(api, "ur5", "operational-space", q=q, frame="tool0", damping=lam, v=np.ones(6))
    J = got["jacobian"]
    A = task_matrix(M, J)
    Lambda = got["inertia"]
    close(Lambda, np.linalg.inv(A + lam**2 * np.eye(6)), 1e-8)
    assert np.linalg.eigvalsh(Lambda)[-1] <= 1 / lam**2 * (1 + 1e-9)  # ‖Λ‖ ≤ 1/λ²
    close(got["dynamically_consistent_inverse"], np.linalg.solve(M, J.T) @ Lambda, 1e-8)
    close(J @ got["dynamically_consistent_inverse"], A @ Lambda, 1e-8)  # not I
    assert not np.allclose(J @ got["dynamically_consistent_inverse"], np.eye(6), atol=1e-3)
    # a damping far below the rounding level of σ_max does not regularize anything
    body = post(api, "ur5", "operational-space", 422, q=q, frame="tool0", damping=1e-12)
    assert body["code"] == "singular_configuration" and "too small" in body["detail"]


def test_a_frame_that_does_not_move(api):
    """The world frame has a zero Jacobian: singular, and with damping Λ = I/λ², J̄ = 0, p = 0."""
    body = post(api, "ur5", "operational-space", 422, q=UR5_Q, frame="universe")
    assert body["code"] == "singular_configuration" and "zero" in body["detail"]
    got = post(
        api, "ur5", "operational-space", q=UR5_Q, frame="universe", damping=0.5, task="linear"
    )
    np.testing.assert_allclose(got["inertia"], np.eye(3) / 0.25, rtol=1e-12)
    assert not got["dynamically_consistent_inverse"].any() and not got["gravity"].any()


def test_a_batch_with_one_singular_state_names_it(api):
    body = post(
        api, "ur5", "operational-space", 422, q=np.stack([UR5_Q, np.zeros(6)]), frame="tool0"
    )
    assert body["detail"].startswith("state 1:") and body["state"] == 1
    got = post(
        api,
        "ur5",
        "operational-space",
        q=np.stack([UR5_Q, np.zeros(6)]),
        frame="tool0",
        damping=0.05,
    )
    assert got["inertia"].shape == (2, 6, 6)
    single = post(api, "ur5", "operational-space", q=UR5_Q, frame="tool0", damping=0.05)
    for key, value in single.items():
        np.testing.assert_array_equal(got[key][0], value)


# -- the binary form and large batches ---------------------------------------------------


@pytest.mark.parametrize(
    ("quantity", "options"),
    [
        ("mass-matrix-inverse", {}),
        ("energy", {}),
        ("center-of-mass", {}),
        ("jacobian", {"frame": "arm_left_7_link", "reference_frame": "local"}),
        ("operational-space", {"frame": "arm_left_7_link", "task": "linear", "damping": 0.01}),
    ],
)
def test_binary_form_and_large_batches(api, catalog_registry, quantity, options):
    """200 talos states (computed off the event loop) in JSON and in the binary form give the
    same numbers, and the same as the states sent one by one."""
    model = catalog_registry.catalog["talos"].model
    rng = np.random.default_rng(9)
    q = np.stack([random_configuration(model, rng) for _ in range(200)])
    v = rng.normal(size=(200, model.nv))
    arrays = {"q": q} if quantity == "mass-matrix-inverse" else {"q": q, "v": v}
    as_json = post(api, "talos", quantity, **arrays, **options)
    r = api.post(
        f"/v1/robots/talos/{quantity}",
        content=binary.encode({**arrays, **options}),
        headers={"content-type": binary.BINARY_MEDIA_TYPE, "accept": binary.BINARY_MEDIA_TYPE},
    )
    assert r.status_code == 200 and r.headers["content-type"] == binary.BINARY_MEDIA_TYPE
    fields, as_binary = binary.decode(r.content)
    assert fields == {} and set(as_binary) == set(as_json)
    for key, value in as_json.items():
        np.testing.assert_array_equal(as_binary[key], value)
        assert value.shape[0] == 200
    for i in (0, 137):
        single = post(api, "talos", quantity, **{k: x[i] for k, x in arrays.items()}, **options)
        for key, value in single.items():
            np.testing.assert_array_equal(as_json[key][i], value)
