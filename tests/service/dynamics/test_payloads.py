"""Payloads composed into a copy of the model: checked against the composition made by hand in
Pinocchio, against independent physics (the potential and kinetic energy of the payload, the
contact forces of a standing robot), and every bad payload is a named domain error."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from service.dynamics.contacts import contact_inverse_dynamics
from service.dynamics.payloads import MAX_PAYLOADS, check_payloads, robot_with_payloads
from service.errors import InvalidInput, UnknownFrame
from service.registry.catalog import catalog_entries
from service.states import States
from tests.helpers import random_configuration

G = 9.81
# a rigid payload: a 0.3 × 0.2 × 0.1 m box of 3 kg, its centre 5 cm along the frame's z
BOX = {
    "mass": 3.0,
    "center_of_mass": [0.01, -0.02, 0.05],
    "inertia": (3.0 / 12 * np.diag([0.2**2 + 0.1**2, 0.3**2 + 0.1**2, 0.3**2 + 0.2**2])).tolist(),
}
CASES = {  # robot -> frames holding payloads (links, joints, fixed frames)
    "ur5": ["tool0", "wrist_2_link"],
    "panda": ["panda_hand", "panda_joint4"],
    "solo12": ["base_link", "FL_FOOT"],
    "talos": ["gripper_left_base_link", "torso_2_link"],
}


def hand_composed(model, payloads):
    """The composition as the contract writes it, done here with Pinocchio directly."""
    out = pin.Model(model)
    for p in payloads:
        frame = out.frames[out.getFrameId(p["frame"])]
        inertia = pin.Inertia(
            p["mass"],
            np.array(p.get("center_of_mass", np.zeros(3))),
            np.array(p.get("inertia", np.zeros((3, 3)))),
        )
        out.inertias[frame.parentJoint] += frame.placement.act(inertia)
    return out


def _robot(registry, name):
    return registry.catalog[name]


@pytest.mark.parametrize("name", sorted(CASES))
def test_every_quantity_is_the_one_of_the_model_composed_by_hand(catalog_registry, name):
    robot = _robot(catalog_registry, name)
    payloads = [{"frame": f, **BOX} for f in CASES[name]]
    before = [pin.Inertia(i) for i in robot.model.inertias]
    carried = robot_with_payloads(robot, payloads)
    reference = hand_composed(robot.model, payloads)
    data, ref = carried.model.createData(), reference.createData()
    rng = np.random.default_rng(7)
    for _ in range(3):
        q = random_configuration(robot.model, rng)
        v, a = rng.normal(size=robot.nv), rng.normal(size=robot.nv)
        np.testing.assert_allclose(
            pin.crba(carried.model, data, q), pin.crba(reference, ref, q), rtol=1e-12, atol=1e-12
        )
        np.testing.assert_allclose(
            pin.rnea(carried.model, data, q, v, a),
            pin.rnea(reference, ref, q, v, a),
            rtol=1e-12,
            atol=1e-10,
        )
        np.testing.assert_allclose(
            pin.centerOfMass(carried.model, data, q),
            pin.centerOfMass(reference, ref, q),
            atol=1e-14,
        )
    assert carried.total_mass == pytest.approx(robot.total_mass + 3.0 * len(payloads), rel=1e-14)
    assert carried.info()["moving_mass"] == carried.total_mass
    # the shared model is untouched
    for old, now in zip(before, robot.model.inertias, strict=True):
        assert old == now
    assert carried.id == robot.id and carried.nq == robot.nq and carried is not robot


def _point_jacobian(model, data, q, fid, c):
    """The world-axes linear Jacobian (3×nv) of the point c (frame coordinates) of frame fid."""
    J = pin.computeFrameJacobian(model, data, q, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    Rc = data.oMf[fid].rotation @ np.asarray(c)
    return J[:3] - pin.skew(Rc) @ J[3:]


@pytest.mark.parametrize(
    "name,frame", [("ur5", "tool0"), ("panda", "panda_hand"), ("talos", "gripper_left_base_link")]
)
def test_gravity_and_kinetic_energy_gain_the_payloads_own(catalog_registry, name, frame):
    """Independently of the composition: a payload of mass m at c adds −m Jcᵀ g⃗ to g(q) (the
    gradient of its potential −m g⃗·p_c) and ½ m |Jc v|² + ½ ωᵀ R I Rᵀ ω to the kinetic energy."""
    robot = _robot(catalog_registry, name)
    carried = robot_with_payloads(robot, [{"frame": frame, **BOX}])
    model, data = robot.model, robot.model.createData()
    fid = robot.frame_ids[frame]
    rng = np.random.default_rng(3)
    for _ in range(3):
        q = random_configuration(model, rng)
        v = rng.normal(size=robot.nv)
        Jc = _point_jacobian(model, data, q, fid, BOX["center_of_mass"])
        gravity_vector = model.gravity.linear
        dg = pin.computeGeneralizedGravity(
            carried.model, carried.model.createData(), q
        ) - pin.computeGeneralizedGravity(model, data, q)
        np.testing.assert_allclose(dg, -BOX["mass"] * Jc.T @ gravity_vector, atol=1e-10)
        omega = (
            pin.computeFrameJacobian(model, data, q, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[
                3:
            ]
            @ v
        )
        R = data.oMf[fid].rotation
        energy = (
            0.5 * BOX["mass"] * np.sum((Jc @ v) ** 2)
            + 0.5 * omega @ R @ np.array(BOX["inertia"]) @ R.T @ omega
        )
        dM = pin.crba(carried.model, carried.model.createData(), q) - pin.crba(model, data, q)
        assert 0.5 * v @ dM @ v == pytest.approx(energy, rel=1e-10, abs=1e-12)


@pytest.mark.parametrize("payload_frame", ["base_link", "FL_FOOT"])
def test_standing_robot_carries_its_weight_and_the_payloads(catalog_registry, payload_frame):
    """Solo-12 standing on its four feet, still: Σ contact forces = (m_robot + m_payload) g⃗,
    with no net horizontal force."""
    robot = _robot(catalog_registry, "solo12")
    payload = {
        "frame": payload_frame,
        "mass": 1.7,
        "center_of_mass": [0.05, 0.02, 0.08],
        "inertia": (0.01 * np.eye(3)).tolist(),
    }
    carried = robot_with_payloads(robot, [payload])
    q, zero = robot.default_configuration, np.zeros(robot.nv)
    feet = [{"frame": f, "type": "point"} for f in ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")]
    states = States({"q": q[None], "v": zero[None], "a": zero[None]}, batched=False)
    out = contact_inverse_dynamics(carried, states, contacts=feet)
    forces = out["contact_forces"][0].reshape(4, 3)
    weight = (robot.total_mass + payload["mass"]) * G
    assert carried.total_mass == pytest.approx(robot.total_mass + payload["mass"], rel=1e-14)
    assert abs(forces[:, 2].sum() - weight) <= 1e-9 * weight
    assert np.abs(forces[:, :2].sum(axis=0)).max() <= 1e-9 * weight
    bare = contact_inverse_dynamics(robot, states, contacts=feet)["contact_forces"][0]
    assert abs(bare.reshape(4, 3)[:, 2].sum() - robot.total_mass * G) <= 1e-9 * weight


def test_a_payload_on_a_link_fixed_to_the_world_adds_fixed_mass_only(catalog_registry):
    robot = _robot(catalog_registry, "ur5")
    carried = robot_with_payloads(robot, [{"frame": "base_link", "mass": 2.5}])
    assert carried.total_mass == robot.total_mass
    assert carried.fixed_mass == pytest.approx(robot.fixed_mass + 2.5, rel=1e-14)
    q = np.array([0.1, -1.0, 1.2, 0.3, -0.4, 0.5])
    np.testing.assert_array_equal(
        pin.computeGeneralizedGravity(carried.model, carried.model.createData(), q),
        pin.computeGeneralizedGravity(robot.model, robot.model.createData(), q),
    )


def test_the_fixed_mass_is_what_the_description_holds_beyond_the_moving_mass(catalog_registry):
    """UR5: the URDF's links weigh 20.9939 kg; 4 kg (its base link) are fixed to the world."""
    robot = _robot(catalog_registry, "ur5")
    entry = next(e for e in catalog_entries() if e.name == "ur5")
    root = ET.parse(entry.path("urdf")).getroot()
    described = sum(float(m.get("value")) for m in root.iter("mass"))
    info = robot.info()
    assert info["total_mass"] == info["moving_mass"] == robot.total_mass
    assert info["moving_mass"] + info["fixed_mass"] == pytest.approx(described, rel=1e-12)
    assert info["fixed_mass"] == pytest.approx(4.0, rel=1e-12)
    solo = _robot(catalog_registry, "solo12").info()  # a free-flyer: everything moves
    assert solo["fixed_mass"] == 0.0 and solo["moving_mass"] == solo["total_mass"]


def test_payload_sets_are_cached_whatever_their_order(catalog_registry):
    robot = _robot(catalog_registry, "ur5")
    a = {"frame": "tool0", "mass": 1.0}
    b = {"frame": "wrist_1_link", "mass": 2.0, "center_of_mass": [0.0, 0.1, 0.0]}
    first = robot_with_payloads(robot, [a, b])
    assert robot_with_payloads(robot, [b, a]) is first
    assert robot_with_payloads(robot, [a]) is not first
    assert robot_with_payloads(robot, []) is robot and robot_with_payloads(robot, None) is robot


BAD = {  # payload -> (error, field named)
    "mass-zero": ({"frame": "tool0", "mass": 0.0}, InvalidInput, "mass"),
    "mass-negative": ({"frame": "tool0", "mass": -1.0}, InvalidInput, "mass"),
    "mass-nan": ({"frame": "tool0", "mass": float("nan")}, InvalidInput, "mass"),
    "mass-inf": ({"frame": "tool0", "mass": float("inf")}, InvalidInput, "mass"),
    "mass-text": ({"frame": "tool0", "mass": "3"}, InvalidInput, "mass"),
    "mass-bool": ({"frame": "tool0", "mass": True}, InvalidInput, "mass"),
    "mass-missing": ({"frame": "tool0"}, InvalidInput, "mass"),
    "inertia-huge": (
        {
            "frame": "tool0",
            "mass": 1.0,  # eigvalsh cannot converge on it
            "inertia": [[1e308, 0, 0], [0, 1e308, 0], [0, 0, 1e308]],
        },
        InvalidInput,
        "inertia",
    ),
    "frame-missing": ({"mass": 1.0}, InvalidInput, "frame"),
    "frame-unknown": ({"frame": "tool9", "mass": 1.0}, UnknownFrame, "frame"),
    "com-short": (
        {"frame": "tool0", "mass": 1.0, "center_of_mass": [0, 0]},
        InvalidInput,
        "center_of_mass",
    ),
    "com-nan": (
        {"frame": "tool0", "mass": 1.0, "center_of_mass": [0, float("nan"), 0]},
        InvalidInput,
        "center_of_mass",
    ),
    "com-text": (
        {"frame": "tool0", "mass": 1.0, "center_of_mass": ["a", 0, 0]},
        InvalidInput,
        "center_of_mass",
    ),
    "inertia-shape": (
        {"frame": "tool0", "mass": 1.0, "inertia": [[1, 0, 0], [0, 1, 0]]},
        InvalidInput,
        "inertia",
    ),
    "inertia-asymmetric": (
        {"frame": "tool0", "mass": 1.0, "inertia": [[1, 0.1, 0], [0, 1, 0], [0, 0, 1]]},
        InvalidInput,
        "inertia",
    ),
    "inertia-negative": (
        {"frame": "tool0", "mass": 1.0, "inertia": np.diag([1, 1, -1e-3]).tolist()},
        InvalidInput,
        "inertia",
    ),
    "inertia-triangle": (
        {"frame": "tool0", "mass": 1.0, "inertia": np.diag([0.1, 0.1, 0.3]).tolist()},
        InvalidInput,
        "inertia",
    ),
    "inertia-inf": (
        {"frame": "tool0", "mass": 1.0, "inertia": [[float("inf"), 0, 0], [0, 1, 0], [0, 0, 1]]},
        InvalidInput,
        "inertia",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_every_bad_payload_is_a_named_domain_error(catalog_registry, case):
    robot = _robot(catalog_registry, "ur5")
    payload, error, field = BAD[case]
    good = {"frame": "tool0", "mass": 1.0}
    with pytest.raises(error) as caught:
        robot_with_payloads(robot, [good, payload])
    assert f"payloads[1].{field}" in caught.value.detail
    if error is InvalidInput:
        assert caught.value.extra["payload"] == 1


def test_limits_of_a_payload_list(catalog_registry):
    robot = _robot(catalog_registry, "ur5")
    with pytest.raises(InvalidInput, match="at most 16"):
        check_payloads(robot, [{"frame": "tool0", "mass": 1.0}] * (MAX_PAYLOADS + 1))
    assert len(check_payloads(robot, [{"frame": "tool0", "mass": 1.0}] * MAX_PAYLOADS)) == 16
    with pytest.raises(InvalidInput, match=r"payloads\[0\] must be an object"):
        check_payloads(robot, [3.0])
    # a point mass and a thin rod (λ₁ = 0, λ₂ = λ₃: the triangle's edge) are rigid bodies
    rod = np.diag([0.0, 0.25, 0.25]).tolist()
    placed = check_payloads(robot, [{"frame": "tool0", "mass": 1.0, "inertia": rod}])
    assert placed[0].inertia == tuple(tuple(row) for row in rod)


def _flange_table() -> list[list[str]]:
    """The rows of docs/payloads.md's table of the catalog arms' flange frames."""
    text = (Path(__file__).parents[3] / "docs" / "payloads.md").read_text()
    section = text.split("### The flange frames of the catalog arms", 1)[1].split("\n\n")[2]
    rows = [
        [cell.strip().strip("`") for cell in line.strip("|").split("|")]
        for line in section.splitlines()
    ]
    return [r for r in rows[2:] if r]


_AXES = {"+x": (0, 1), "-x": (0, -1), "+y": (1, 1), "-y": (1, -1), "+z": (2, 1), "-z": (2, -1)}


@pytest.mark.parametrize("row", _flange_table(), ids=lambda r: f"{r[0]}-{r[1]}")
def test_the_documented_flange_axes_are_the_models(catalog_registry, row):
    """Each documented flange frame: its axis 'out of the flange' points from the last joint's
    origin to the frame's origin, at the documented distance, and the last joint turns about
    the documented axis of the frame (Pinocchio's frame Jacobian, LOCAL), at any q."""
    robot_id, frame, out, joint_axis, distance = row
    robot = catalog_registry.catalog[robot_id]
    model, data = robot.model, robot.model.createData()
    fid = model.getFrameId(frame)
    joint = model.frames[fid].parentJoint
    for q in (pin.neutral(model), pin.randomConfiguration(model)):
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        oMf, oMj = data.oMf[fid], data.oMi[joint]
        offset = oMf.rotation.T @ (oMf.translation - oMj.translation)  # in the frame's axes
        index, sign = _AXES[out.replace("−", "-")]
        np.testing.assert_allclose(
            offset / np.linalg.norm(offset), sign * np.eye(3)[index], atol=1e-9
        )
        assert np.linalg.norm(offset) == pytest.approx(float(distance.split()[0]), abs=5e-5)
        J = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
        index, sign = _AXES[joint_axis.replace("−", "-")]
        axis = J[3:, model.joints[joint].idx_v]
        np.testing.assert_allclose(axis, sign * np.eye(3)[index], atol=1e-9)
