"""Payload capacity: the exact answer (τ affine in m) against a brute-force scan of the mass with
the payload composed by hand and Pinocchio's RNEA, on arms and a free-flyer, holding still and
moving; batches, already-carried payloads, limits overridden, and the edge cases."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.dynamics.payload_capacity import (
    ZERO_TORQUE_PER_KG,
    chain_reach,
    unit_mass_robot,
    zero_torque_per_kg,
)
from service.dynamics.payload_capacity import capacity as payload_capacity
from service.dynamics.payloads import robot_with_payloads
from service.errors import DimensionMismatch, InvalidInput, UnknownFrame
from service.registry.robot import Robot
from tests.helpers import planar_arm_closed_form, planar_arm_urdf, random_configuration

CASES = {  # robot -> (frame, centre of mass in the frame)
    "ur5": ("tool0", [0.0, 0.02, 0.1]),
    "panda": ("panda_hand", [0.0, 0.0, 0.1]),
    "talos": ("gripper_left_base_link", [0.02, 0.0, -0.05]),
}


def torques(model, frame: str, com, mass: float, q, v, a) -> np.ndarray:
    """RNEA with a point mass composed by hand: inertias[parent] += placement · Inertia."""
    carried = pin.Model(model)
    f = carried.frames[carried.getFrameId(frame)]
    carried.inertias[f.parentJoint] += f.placement.act(
        pin.Inertia(mass, np.asarray(com, dtype=float), np.zeros((3, 3)))
    )
    return pin.rnea(carried, carried.createData(), q, v, a)


def limits_of(robot) -> np.ndarray:
    limit = np.array(robot.model.effortLimit, dtype=float)
    limit[~np.isfinite(limit) | (limit >= np.finfo(float).max)] = 0.0
    if robot.root_joint == "free-flyer":
        limit[:6] = 0.0
    return limit


def feasible(tau: np.ndarray, limit: np.ndarray) -> np.ndarray:
    limited = limit > 0
    return np.all(np.abs(tau[..., limited]) <= limit[limited], axis=-1)


def states(robot, rng, n: int, moving: bool):
    q = np.array([random_configuration(robot.model, rng) for _ in range(n)])
    if robot.root_joint == "free-flyer":  # an upright base, the arms and legs anywhere
        q[:, :7] = robot.default_configuration[:7]
    scale = 1.0 if moving else 0.0
    return (q, scale * rng.normal(size=(n, robot.nv)), scale * rng.normal(size=(n, robot.nv)))


@pytest.mark.parametrize("moving", [False, True], ids=["still", "moving"])
@pytest.mark.parametrize("name", sorted(CASES))
def test_capacity_is_the_heaviest_mass_of_a_brute_force_scan(catalog_registry, name, moving):
    robot = catalog_registry.catalog[name]
    frame, com = CASES[name]
    limit = limits_of(robot)
    rng = np.random.default_rng(11)
    q, v, a = states(robot, rng, 4, moving)
    cap = payload_capacity(robot, q, frame, center_of_mass=com, v=v, a=a)
    for i in range(q.shape[0]):
        m_star = cap.mass[i]
        if not np.isfinite(m_star):
            continue
        # the scan: the heaviest feasible mass on a grid up to twice the answer
        grid = np.linspace(0.0, 2.0 * m_star + 1.0, 401)
        ok = [feasible(torques(robot.model, frame, com, m, q[i], v[i], a[i]), limit) for m in grid]
        scanned = grid[np.flatnonzero(ok)].max() if any(ok) else None
        step = grid[1] - grid[0]
        if m_star == 0.0:
            assert not ok[0]  # over a limit with no payload already
        else:
            assert scanned is not None and scanned <= m_star + 1e-9 <= scanned + step + 1e-9
        # exactly at the boundary: feasible just below, the limiting joint over just above
        tau_at = torques(robot.model, frame, com, m_star, q[i], v[i], a[i])
        np.testing.assert_allclose(cap.tau[i], tau_at, rtol=1e-9, atol=1e-9)
        k = int(cap.limiting_index[i])
        assert limit[k] > 0 and robot.joint_types[cap.limiting_joint(i)] != "free_flyer"
        if m_star > 0:
            assert abs(abs(tau_at[k]) - limit[k]) <= 1e-9 * limit[k]
            above = torques(robot.model, frame, com, m_star * (1 + 1e-6), q[i], v[i], a[i])
            assert abs(above[k]) > limit[k]
            below = torques(robot.model, frame, com, m_star * (1 - 1e-9), q[i], v[i], a[i])
            assert feasible(below, limit)
        # each coordinate's own bound, brute force: feasible for that coordinate alone
        for j in np.flatnonzero(limit > 0):
            mj = cap.mass_per_joint[i, j]
            if np.isfinite(mj) and mj > 0:
                t = torques(robot.model, frame, com, mj * (1 - 1e-9), q[i], v[i], a[i])
                assert abs(t[j]) <= limit[j]
                t = torques(robot.model, frame, com, mj * (1 + 1e-6), q[i], v[i], a[i])
                assert abs(t[j]) > limit[j]
    # the free-flyer root's rows are never limits
    if robot.root_joint == "free-flyer":
        assert np.isinf(cap.mass_per_joint[:, :6]).all()


def test_the_torque_per_kg_is_rnea_of_the_unit_mass_alone(catalog_registry):
    """τ₁ = RNEA(model + 1 kg) − RNEA(model), motion terms included and armature excluded
    (Talos has armature)."""
    robot = catalog_registry.catalog["talos"]
    assert np.abs(robot.model.armature).max() > 0
    frame, com = CASES["talos"]
    unit = unit_mass_robot(robot, robot.frame_ids[frame], np.array(com))
    rng = np.random.default_rng(5)
    q, v, a = states(robot, rng, 2, moving=True)
    for i in range(2):
        want = torques(robot.model, frame, com, 1.0, q[i], v[i], a[i]) - pin.rnea(
            robot.model, robot.model.createData(), q[i], v[i], a[i]
        )
        got = pin.rnea(unit.model, unit.model.createData(), q[i], v[i], a[i])
        np.testing.assert_allclose(got, want, atol=1e-9)


def test_a_batch_is_its_states_and_its_minimum(catalog_registry):
    robot = catalog_registry.catalog["ur5"]
    rng = np.random.default_rng(2)
    q, v, a = states(robot, rng, 80, moving=True)  # parallel RNEA from 64 states
    cap = payload_capacity(robot, q, "tool0", v=v, a=a)
    for i in (0, 17, 79):
        one = payload_capacity(robot, q[i : i + 1], "tool0", v=v[i : i + 1], a=a[i : i + 1])
        np.testing.assert_allclose(one.tau[0], cap.tau[i], rtol=1e-12, atol=1e-12)
        assert one.mass[0] == pytest.approx(cap.mass[i], rel=1e-12)
    answer = cap.answer(batched=True)
    low = int(np.argmin(cap.mass))
    ranges = np.array(answer["mass_range"], dtype=float)  # every state holds some mass here
    assert answer["minimum"] == {
        "mass": cap.mass[low],
        "state": low,
        "limiting_joint": cap.limiting_joint(low),
        "mass_range": [ranges[:, 0].max(), ranges[:, 1].min()],
    }
    assert len(answer["mass"]) == len(answer["limiting_joint"]) == 80
    single = payload_capacity(robot, q[:1], "tool0").answer(batched=False)
    assert isinstance(single["mass"], float) and len(single["tau"]) == 6
    assert "minimum" not in single


def test_a_carried_payload_at_the_same_point_takes_its_mass_off_the_capacity(catalog_registry):
    robot = catalog_registry.catalog["panda"]
    q = np.array([random_configuration(robot.model, np.random.default_rng(9))])
    com = [0.0, 0.0, 0.1]
    free = payload_capacity(robot, q, "panda_hand", center_of_mass=com).mass[0]
    carried = [{"frame": "panda_hand", "mass": 0.4 * free, "center_of_mass": com}]
    left = payload_capacity(robot, q, "panda_hand", center_of_mass=com, payloads=carried)
    assert left.mass[0] == pytest.approx(0.6 * free, rel=1e-9)


def test_over_the_limit_already_none_limiting_and_overridden_limits(catalog_registry):
    robot = catalog_registry.catalog["ur5"]
    q = np.array([[0.0, -1.2, 1.0, 0.3, 0.2, 0.1]])
    g = pin.computeGeneralizedGravity(robot.model, robot.model.createData(), q[0])
    limits = np.full(6, 1000.0)
    limits[2] = 0.5 * abs(g[2])  # the elbow cannot even hold the arm
    limits[1] = 0.9 * abs(g[1])  # the shoulder neither, and is further over
    cap = payload_capacity(robot, q, "tool0", effort_limits=limits)
    assert cap.mass[0] == 0.0 and cap.limiting_joint(0) == "elbow_joint"
    assert cap.mass_per_joint[0, 1] == 0.0 and cap.mass_per_joint[0, 2] == 0.0
    np.testing.assert_allclose(cap.tau[0], g, atol=1e-12)
    unlimited = payload_capacity(robot, q, "tool0", effort_limits=np.zeros(6))
    assert np.isinf(unlimited.mass[0]) and unlimited.limiting_joint(0) is None
    answer = unlimited.answer(batched=False)
    assert answer["mass"] is None and answer["mass_per_joint"] == [None] * 6
    # a frame fixed to the world: no joint feels the mass
    world = payload_capacity(robot, q, "base_link").answer(batched=True)
    assert world["mass"] == [None] and world["minimum"]["mass"] is None
    # shoulder pan and wrist 3 never feel a mass on tool0's axis at rest: null, not 1e17 kg
    axis = payload_capacity(robot, q, "tool0", center_of_mass=[0, 0, 0.1])
    assert np.isinf(axis.mass_per_joint[0, [0, 5]]).all()


def test_bad_inputs_are_domain_errors(catalog_registry):
    robot = catalog_registry.catalog["ur5"]
    q = np.zeros((1, 6))
    with pytest.raises(UnknownFrame):
        payload_capacity(robot, q, "tool9")
    with pytest.raises(DimensionMismatch):
        payload_capacity(robot, q, "tool0", effort_limits=np.ones(5))
    with pytest.raises(InvalidInput):
        payload_capacity(robot, q, "tool0", effort_limits=-np.ones(6))
    with pytest.raises(InvalidInput):
        payload_capacity(robot, q, "tool0", center_of_mass=[0, 0])
    with pytest.raises(InvalidInput, match=r"payloads\[0\]\.mass"):
        payload_capacity(robot, q, "tool0", payloads=[{"frame": "tool0", "mass": -1}])
    assert robot_with_payloads(robot, []) is robot


def test_planar_arm_capacity_against_its_closed_form():
    """A point mass at the tip of the two-link arm is a heavier tip: τ(m) is the hand-derived
    M a + C v + g with m₂ + m. At the capacity the limiting joint is exactly at its limit (100
    N·m) and every other within it; a little more mass breaks the limit."""
    l1, l2, m1, m2 = 0.7, 0.5, 1.5, 0.8
    robot = Robot(
        id="arm",
        name="arm",
        source="upload",
        root_joint="fixed",
        model=pin.buildModelFromXML(planar_arm_urdf(l1, l2, m1, m2)),
    )
    rng = np.random.default_rng(4)
    q = rng.uniform(-3, 3, size=(6, 2))
    v, a = rng.normal(size=(6, 2)), rng.normal(size=(6, 2))
    v[:2], a[:2] = 0.0, 0.0  # two states holding still

    def closed(i: int, mass: float) -> np.ndarray:
        M, C, g = planar_arm_closed_form(l1, l2, m1, m2 + mass, q[i], v[i])
        return M @ a[i] + C @ v[i] + g

    cap = payload_capacity(robot, q, "link2", center_of_mass=[l2, 0, 0], v=v, a=a)
    for i in range(6):
        m_star, k = cap.mass[i], int(cap.limiting_index[i])
        assert 0 < m_star < np.inf
        at = closed(i, m_star)
        np.testing.assert_allclose(cap.tau[i], at, rtol=1e-10, atol=1e-9)
        assert abs(abs(at[k]) - 100.0) <= 1e-9 and np.all(np.abs(at) <= 100.0 + 1e-9)
        assert np.abs(closed(i, m_star * (1 + 1e-6))).max() > 100.0


def test_joints_without_a_limit_in_the_description_never_limit(catalog_registry):
    robot = catalog_registry.catalog["double_pendulum"]  # no effort limits at all
    cap = payload_capacity(robot, np.array([[0.3, 0.2]]), "link2")
    assert np.isinf(cap.mass[0]) and cap.limiting_joint(0) is None
    np.testing.assert_allclose(
        cap.tau[0],
        pin.computeGeneralizedGravity(robot.model, robot.model.createData(), np.array([0.3, 0.2])),
        atol=1e-12,
    )


def test_a_point_on_the_joint_axes_never_limits_in_any_state(catalog_registry):
    """The origin of the UR5's shoulder-lift joint lies on its axis, and at rest its weight
    acts along the vertical shoulder-pan axis: neither joint (nor any after them) feels a mass
    held there, so in every state it is null, never limiting — not 10¹⁹ kg, the rounding of
    RNEA taken for a torque (its largest entry is itself rounding there). Moving, the pan
    joint feels it (the point is 0.136 m off its axis) and limits it as a brute-force RNEA
    with the mass composed by hand says; the lift joint still never does."""
    robot = catalog_registry.catalog["ur5"]
    frame, com = "shoulder_lift_joint", [0.0, 0.0, 0.0]
    rng = np.random.default_rng(37)
    q, _, _ = states(robot, rng, 200, moving=False)
    still = payload_capacity(robot, q, frame, center_of_mass=com)
    assert np.isinf(still.mass).all() and np.isinf(still.mass_per_joint).all()
    assert still.minimum()["mass"] is None
    q, v, a = states(robot, rng, 20, moving=True)
    moving = payload_capacity(robot, q, frame, center_of_mass=com, v=v, a=a)
    limit = limits_of(robot)
    assert np.isinf(moving.mass_per_joint[:, 1:]).all()
    assert np.isfinite(moving.mass_per_joint[:, 0]).all()
    for i in range(20):
        m = moving.mass_per_joint[i, 0]
        if m > 0:
            assert (
                abs(torques(robot.model, frame, com, m * (1 - 1e-9), q[i], v[i], a[i])[0])
                <= limit[0]
            )
            assert (
                abs(torques(robot.model, frame, com, m * (1 + 1e-6), q[i], v[i], a[i])[0])
                > limit[0]
            )


def test_the_zero_of_a_torque_per_kg_comes_from_the_model_and_the_state():
    """ε₁ = 1e-10 · Λ · (‖g‖ + Λ Σ|a| + Λ (Σ|v|)²), Λ = max(R, 1 m), R the chain's reach: for
    the two-link arm holding a point at its tip, R = l1 + l2 (+ the point's offset), by hand."""
    l1, l2 = 0.7, 0.5
    robot = Robot(
        id="arm",
        name="arm",
        source="upload",
        root_joint="fixed",
        model=pin.buildModelFromXML(planar_arm_urdf(l1, l2, 1.5, 0.8)),
    )
    fid = robot.model.getFrameId("link2")
    tip = np.array([l2, 0.0, 0.0])
    assert chain_reach(robot, fid, tip) == pytest.approx(l1 + l2, rel=1e-15)
    lever = max(l1 + 2 * l2, 1.0)  # the point 0.5 m beyond the tip
    v, a = np.array([[0.0, 0.0], [1.0, -2.0]]), np.array([[0.0, 0.0], [3.0, 0.5]])
    want = ZERO_TORQUE_PER_KG * lever * (9.81 + lever * np.array([0.0, 3.5 + 3.0**2]))
    np.testing.assert_allclose(zero_torque_per_kg(robot, fid, 2 * tip, v, a), want, rtol=1e-14)


def _counterweight_case(robot):
    """The UR5 at q = (0, −0.3, 0, 0, 0, 0) with a point mass 0.25 m along −z of upper_arm_link
    and the shoulder-lift limit at 45.26 N·m: gravity alone is over that limit (56.6 N·m), and
    the mass, on the other side of the shoulder's axis, pulls the torque back."""
    q = np.array([[0.0, -0.3, 0.0, 0.0, 0.0, 0.0]])
    limit = limits_of(robot)
    limit[1] = 45.26
    return q, limit, [0.0, 0.0, -0.25]


def test_a_counterweight_is_a_range_of_masses(catalog_registry):
    robot = catalog_registry.catalog["ur5"]
    q, limit, com = _counterweight_case(robot)
    cap = payload_capacity(robot, q, "upper_arm_link", center_of_mass=com, effort_limits=limit)
    answer = cap.answer(batched=False)
    lo, hi = answer["mass_range"]
    assert (round(lo, 2), round(hi, 2)) == (4.83, 43.47)  # the numbers
    assert answer["mass"] == hi and answer["limiting_joint"] == "shoulder_lift_joint"
    assert answer["mass_per_joint"][1] == hi
    # brute force: the masses within every limit, composed by hand, are exactly [lo, hi]
    zero = np.zeros(6)
    grid = np.linspace(0.0, 60.0, 6001)
    ok = np.array(
        [
            feasible(torques(robot.model, "upper_arm_link", com, m, q[0], zero, zero), limit)
            for m in grid
        ]
    )
    inside = grid[ok]
    assert inside.min() == pytest.approx(lo, abs=0.01) and inside.max() == pytest.approx(
        hi, abs=0.01
    )
    assert ok[(grid >= lo + 1e-9) & (grid <= hi - 1e-9)].all()
    for end in (lo, hi):
        tau = torques(robot.model, "upper_arm_link", com, end, q[0], zero, zero)
        assert abs(tau[1]) == pytest.approx(45.26, rel=1e-12)  # each end exactly at the limit


def test_a_joint_no_mass_can_help_empties_the_range(catalog_registry):
    """The elbow over a limit the mass does not load (its weight is on the shoulder's side):
    no mass suits it, the range is empty and the capacity 0, the elbow limiting."""
    robot = catalog_registry.catalog["ur5"]
    q, limit, com = _counterweight_case(robot)
    limit[2] = 10.0  # the elbow holds 15 N·m with no payload
    cap = payload_capacity(robot, q, "upper_arm_link", center_of_mass=com, effort_limits=limit)
    answer = cap.answer(batched=False)
    assert answer["mass_range"] is None and answer["mass"] == 0.0
    assert answer["limiting_joint"] == "elbow_joint" and answer["mass_per_joint"][2] == 0.0
    assert answer["mass_per_joint"][1] == pytest.approx(43.47, abs=0.005)  # its own upper end


def test_a_batch_range_is_the_masses_that_suit_every_state(catalog_registry):
    """The counterweight case with the shoulder at −0.3 and −0.5 rad: each state has its
    range, the batch's is their intersection [max lo, min hi]."""
    robot = catalog_registry.catalog["ur5"]
    q, limit, com = _counterweight_case(robot)
    batch = np.concatenate([q, q])
    batch[1, 1] = -0.5
    answer = payload_capacity(
        robot, batch, "upper_arm_link", center_of_mass=com, effort_limits=limit
    ).answer(batched=True)
    (lo0, hi0), (lo1, hi1) = answer["mass_range"]
    assert lo1 < lo0 < hi0 < hi1  # the steeper shoulder needs less counterweight
    assert answer["minimum"]["mass_range"] == [lo0, hi0]
    assert answer["minimum"]["mass"] == hi0 and answer["minimum"]["state"] == 0


def test_the_counterweight_over_http(api):
    body = {
        "q": [0.0, -0.3, 0.0, 0.0, 0.0, 0.0],
        "frame": "upper_arm_link",
        "center_of_mass": [0.0, 0.0, -0.25],
        "effort_limits": {
            "shoulder_pan_joint": 150.0,
            "shoulder_lift_joint": 45.26,
            "elbow_joint": 150.0,
            "wrist_1_joint": 28.0,
            "wrist_2_joint": 28.0,
            "wrist_3_joint": 28.0,
        },
    }
    answer = api.post("/v1/robots/ur5/payload-capacity", json=body)
    assert answer.status_code == 200, answer.text
    got = answer.json()
    assert [round(x, 2) for x in got["mass_range"]] == [4.83, 43.47]
    assert got["mass"] == got["mass_range"][1]
