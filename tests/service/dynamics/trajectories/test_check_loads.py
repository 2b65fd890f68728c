"""The trajectory check's sizing figures per 1-DoF joint — rms_effort, peak_power and the four
peak loads — against an independent evaluation: scipy's not-a-knot spline at every evaluated
point, Pinocchio's RNEA and its data.f, the integrals by numpy's trapezoidal rule; with a
friction model, with a payload over HTTP, and by hand for a link held still."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.interpolate import CubicSpline

from service.dynamics.trajectories import check_trajectory
from service.registry import Registry
from service.registry.robot import Robot

G = 9.81
LOADS = ("peak_force", "peak_moment", "peak_axial_force", "peak_bending_moment")


@pytest.fixture(scope="module")
def robots(tmp_path_factory: pytest.TempPathFactory) -> Registry:
    registry = Registry(tmp_path_factory.mktemp("loads"), ["ur5", "planar_arm"])
    registry.load()
    return registry


def _motion(nq: int, n: int = 21, duration: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(4)
    t = np.linspace(0.0, duration, n)
    amp, freq, phase = rng.uniform(0.2, 0.8, nq), rng.uniform(0.3, 1.0, nq), rng.uniform(0, 6, nq)
    return t, amp * np.sin(freq * t[:, None] * 2 + phase)


def _reference(model, t, q, k, friction=None) -> list[dict[str, float]]:
    """The figures by an independent route: every evaluated point of the spline, RNEA and
    data.f there, friction added to τ and along the axis."""
    spline = CubicSpline(t, q, bc_type="not-a-knot")
    times = np.concatenate(
        [
            np.concatenate(
                [t[i] + (t[i + 1] - t[i]) * np.arange(k) / k for i in range(len(t) - 1)]
            ),
            t[-1:],
        ]
    )
    qs, vs, accs = spline(times), spline(times, 1), spline(times, 2)
    data = model.createData()
    tau = np.empty((times.size, model.nv))
    wrench = np.empty((times.size, model.njoints - 1, 6))
    for i in range(times.size):
        tau[i] = pin.rnea(model, data, qs[i], vs[i], accs[i])
        wrench[i] = [data.f[j].vector for j in range(1, model.njoints)]
    axes = []
    for j in range(1, model.njoints):
        S = _subspace(model.joints[j], model)
        axes.append(S[3:] / np.linalg.norm(S[3:]))  # every joint here is revolute
    axes = np.array(axes)
    if friction is not None:
        torque = friction(vs)
        tau = tau + torque
        wrench[:, :, 3:] += torque[:, :, None] * axes
    f, n = wrench[..., :3], wrench[..., 3:]
    along = np.einsum("njk,jk->nj", n, axes)
    out = []
    for j in range(model.nv):
        out.append(
            {
                "rms_effort": float(np.sqrt(np.trapezoid(tau[:, j] ** 2, times) / (t[-1] - t[0]))),
                "peak_power": float(np.abs(tau[:, j] * vs[:, j]).max()),
                "peak_force": float(np.linalg.norm(f[:, j], axis=1).max()),
                "peak_moment": float(np.linalg.norm(n[:, j], axis=1).max()),
                "peak_axial_force": float(np.abs(f[:, j] @ axes[j]).max()),
                "peak_bending_moment": float(
                    np.linalg.norm(n[:, j] - along[:, j, None] * axes[j], axis=1).max()
                ),
            }
        )
    return out


def _subspace(joint, model) -> np.ndarray:
    jdata = joint.createData()
    joint.calc(jdata, pin.neutral(model))
    return np.asarray(jdata.S).reshape(6)


@pytest.mark.parametrize("k", [1, 4])
def test_sizing_figures_equal_an_independent_evaluation(robots: Registry, k: int) -> None:
    robot = robots.get("ur5")
    t, q = _motion(6)
    result = check_trajectory(robot, t, q, samples_per_interval=k)
    for joint, expected in zip(result.joints, _reference(robot.model, t, q, k), strict=True):
        for name, value in expected.items():
            assert joint[name] == pytest.approx(value, rel=1e-9, abs=1e-9), (joint["name"], name)


def test_friction_counts_in_the_effort_power_and_loads(robots: Registry) -> None:
    base = robots.get("ur5")
    friction = {"coulomb": np.full(6, 2.0), "viscous": np.full(6, 1.5), "offset": np.zeros(6)}
    rough = Robot(
        id="ur5_rough",
        name="ur5_rough",
        source="upload",
        root_joint="fixed",
        model=base.model,
        friction=friction,
    )

    def torque(v: np.ndarray) -> np.ndarray:
        return friction["coulomb"] * np.sign(v) + friction["viscous"] * v

    t, q = _motion(6)
    result = check_trajectory(rough, t, q, friction=torque)
    plain = check_trajectory(base, t, q)
    for joint, bare, expected in zip(
        result.joints, plain.joints, _reference(base.model, t, q, 4, torque), strict=True
    ):
        for name, value in expected.items():
            assert joint[name] == pytest.approx(value, rel=1e-9, abs=1e-9), (joint["name"], name)
        assert joint["peak_force"] == pytest.approx(bare["peak_force"], rel=1e-12)  # along s only
        assert joint["rms_effort"] != pytest.approx(bare["rms_effort"], rel=1e-3)


def test_a_held_two_link_arm_by_hand(robots: Registry) -> None:
    """Held still, horizontal: constant loads, the RMS effort is the holding torque, no power."""
    robot = robots.get("planar_arm")
    t = np.array([0.0, 1.0, 3.0])
    q, v = np.zeros((3, 2)), np.zeros((3, 2))
    result = check_trajectory(robot, t, q, v, np.zeros((3, 2)))
    shoulder, elbow = result.joints
    m1, m2, l1, l2 = 2.0, 1.5, 1.0, 0.7
    assert shoulder["rms_effort"] == pytest.approx(G * (m1 * l1 + m2 * (l1 + l2)), rel=1e-12)
    assert elbow["rms_effort"] == pytest.approx(G * m2 * l2, rel=1e-12)
    assert shoulder["peak_power"] == elbow["peak_power"] == 0.0
    assert shoulder["peak_force"] == pytest.approx((m1 + m2) * G, rel=1e-12)
    assert elbow["peak_moment"] == pytest.approx(G * m2 * l2, rel=1e-12)
    assert shoulder["peak_bending_moment"] == pytest.approx(0.0, abs=1e-12)
    assert shoulder["peak_axial_force"] == pytest.approx(0.0, abs=1e-12)


def test_http_answer_carries_the_figures_with_payloads(small_app_factory) -> None:
    client = small_app_factory(catalog="ur5")
    robot = client.app.state.registry.catalog["ur5"]
    t, q = _motion(6, n=9)
    payload = {"frame": "tool0", "mass": 4.0, "center_of_mass": [0.0, 0.0, 0.1]}
    body = {"t": t.tolist(), "q": q.tolist(), "payloads": [payload]}
    answer = client.post("/v1/robots/ur5/trajectory-check", json=body)
    assert answer.status_code == 200, answer.text
    carried = pin.Model(robot.model)
    tool = carried.frames[carried.getFrameId("tool0")]
    carried.inertias[tool.parentJoint] += tool.placement.act(
        pin.Inertia(4.0, np.array([0.0, 0.0, 0.1]), np.zeros((3, 3)))
    )
    for joint, expected in zip(answer.json()["joints"], _reference(carried, t, q, 4), strict=True):
        for name, value in expected.items():
            assert joint[name] == pytest.approx(value, rel=1e-9, abs=1e-9), (joint["name"], name)


def test_a_robot_without_1_dof_joints_has_no_figures() -> None:
    """A free-flying body (a drone's model: its one joint is the free-flyer): checked, no joint
    entries, τ the wrench that moves the base."""
    body = """<robot name="drone"><link name="base"><inertial><mass value="1.5"/>
<inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.04"/></inertial></link></robot>"""
    model = pin.buildModelFromXML(body, pin.JointModelFreeFlyer())
    drone = Robot(id="drone", name="drone", source="upload", root_joint="free-flyer", model=model)
    t = np.array([0.0, 0.5, 1.0])
    q = np.tile(pin.neutral(model), (3, 1))
    result = check_trajectory(drone, t, q, np.zeros((3, 6)), np.zeros((3, 6)))
    assert result.joints == [] and result.feasible
    np.testing.assert_allclose(result.tau[:, 2], 1.5 * G, rtol=1e-12)  # its weight, held up
