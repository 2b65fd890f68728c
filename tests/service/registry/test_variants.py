"""Variants: stored derived models (payloads and/or locked joints). Their dynamics are the
parent's with the payloads composed (and the joints locked), their ids are content-derived
(equal across registries, whatever the payloads' order), they survive a restart and the
deletion of their parent, and `reduce` keeps the ids it always gave."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from service.dynamics.payloads import check_payloads, robot_with_payloads
from service.errors import InvalidInput
from service.registry import Registry
from service.registry.reduce import as_lists
from service.registry.store import reduced_id
from tests.helpers import planar_arm_urdf

Q = np.array([0.2, -1.1, 1.3, -0.4, 0.6, 0.1])
TOOL = {
    "frame": "tool0",
    "mass": 3.0,
    "center_of_mass": [0.0, 0.0, 0.05],
    "inertia": np.diag([0.01, 0.01, 0.005]).tolist(),
}
WRIST = {"frame": "wrist_2_link", "mass": 0.5}


def registry(data_dir: Path) -> Registry:
    out = Registry(data_dir, ["ur5", "planar_arm"])
    out.load()
    return out


def mass_matrix(robot, q) -> np.ndarray:
    return pin.crba(robot.model, robot.model.createData(), q)


def test_a_variant_is_the_parent_carrying_its_payloads_and_is_stored(tmp_path):
    reg = registry(tmp_path)
    ur5 = reg.get("ur5")
    variant, created = reg.variant(
        "ur5", payloads=check_payloads(ur5, [TOOL, WRIST]), name="ur5 with a tool"
    )
    assert created and variant.id.startswith("v-") and variant.name == "ur5 with a tool"
    info = variant.info()
    assert info["parent"] == "ur5" and info["source"] == "upload"
    assert [p["frame"] for p in info["modifications"]["payloads"]] == ["tool0", "wrist_2_link"]
    assert info["modifications"]["payloads"][1] == {
        "frame": "wrist_2_link",
        "mass": 0.5,
        "center_of_mass": [0.0, 0.0, 0.0],
        "inertia": [[0.0] * 3] * 3,
    }
    assert "locked_joints" not in info["modifications"]
    assert info["total_mass"] == pytest.approx(ur5.total_mass + 3.5, rel=1e-14)
    carried = robot_with_payloads(ur5, [TOOL, WRIST])
    np.testing.assert_array_equal(mass_matrix(variant, Q), mass_matrix(carried, Q))
    assert ur5.total_mass == pytest.approx(16.9939)  # the parent is untouched
    again, created = reg.variant("ur5", payloads=check_payloads(ur5, [WRIST, TOOL]))
    assert not created and again.id == variant.id
    assert variant.id in {s["id"] for s in reg.summaries()}


def test_ids_agree_across_registries_and_survive_a_restart(tmp_path):
    one, two = registry(tmp_path / "a"), registry(tmp_path / "b")
    made = [
        r.variant("ur5", payloads=check_payloads(r.get("ur5"), p))[0]
        for r, p in ((one, [TOOL, WRIST]), (two, [WRIST, TOOL]))
    ]
    assert made[0].id == made[1].id
    different, _ = one.variant(
        "ur5", payloads=check_payloads(one.get("ur5"), [{**TOOL, "mass": 3.1}])
    )
    assert different.id != made[0].id
    restarted = registry(tmp_path / "a")
    back = restarted.get(made[0].id)
    np.testing.assert_array_equal(mass_matrix(back, Q), mass_matrix(made[0], Q))
    assert back.info() == made[0].info()


def test_deleting_the_parent_leaves_its_variants_working(tmp_path):
    reg = registry(tmp_path)
    arm, _ = reg.upload(
        urdf=planar_arm_urdf(0.7, 0.5, 1.5, 0.8),
        root_joint="fixed",
        gravity=None,
        name="arm",
        inertia_check="reject",
    )
    tip = [{"frame": "link2", "mass": 2.0, "center_of_mass": [0.5, 0.0, 0.0]}]
    variant, _ = reg.variant(arm.id, payloads=check_payloads(arm, tip))
    # a variant of the variant: one more payload, and the elbow locked
    nested, _ = reg.variant(
        variant.id, payloads=check_payloads(variant, tip), locked_joints={"elbow": 0.3}
    )
    q = np.array([0.4, 0.3])
    want_M = mass_matrix(variant, q)
    reg.delete(arm.id)
    with pytest.raises(Exception, match="no robot"):
        reg.get(arm.id)
    np.testing.assert_array_equal(mass_matrix(reg.get(variant.id), q), want_M)
    restarted = registry(tmp_path)
    np.testing.assert_array_equal(mass_matrix(restarted.get(variant.id), q), want_M)
    restarted.delete(variant.id)
    rebuilt = restarted.get(nested.id)
    assert rebuilt.nv == 1 and rebuilt.info()["parent"] == variant.id
    # the arm with 4 kg at the tip (two payloads), elbow locked: M is the shoulder's entry
    heavier = Registry(tmp_path / "other", ["planar_arm"])
    heavier.load()
    ref, _ = heavier.upload(
        urdf=planar_arm_urdf(0.7, 0.5, 1.5, 4.8),
        root_joint="fixed",
        gravity=None,
        name="arm",
        inertia_check="reject",
    )
    np.testing.assert_allclose(mass_matrix(rebuilt, q[:1]), mass_matrix(ref, q)[:1, :1], rtol=1e-12)


def test_payloads_and_locked_joints_together(tmp_path):
    reg = registry(tmp_path)
    ur5 = reg.get("ur5")
    variant, _ = reg.variant(
        "ur5",
        payloads=check_payloads(ur5, [TOOL]),
        locked_joints={"wrist_3_joint": 0.1, "elbow_joint": 1.3},
    )
    assert variant.nv == 4 and variant.info()["modifications"]["locked_joints"] == {
        "wrist_3_joint": [0.1],
        "elbow_joint": [1.3],
    }
    full = mass_matrix(robot_with_payloads(ur5, [TOOL]), Q)
    keep = [0, 1, 3, 4]
    np.testing.assert_allclose(
        mass_matrix(variant, Q[keep]), full[np.ix_(keep, keep)], rtol=1e-12, atol=1e-12
    )


def test_reduce_is_the_variant_with_locked_joints_alone_and_keeps_its_ids(tmp_path):
    reg = registry(tmp_path)
    locked = {"wrist_3_joint": 0.1}
    reduced, created = reg.reduce("ur5", locked)
    assert created and reduced.id == reduced_id("ur5", as_lists(locked))
    same, created = reg.variant("ur5", locked_joints=locked)
    assert not created and same.id == reduced.id
    info = reduced.info()
    assert info["parent"] == "ur5" and info["modifications"] == {
        "locked_joints": {"wrist_3_joint": [0.1]}
    }
    assert info["reduced_from"]["locked_joints"] == {"wrist_3_joint": [0.1]}
    assert registry(tmp_path).get(reduced.id).info() == info
    with pytest.raises(InvalidInput, match="at least one modification"):
        reg.variant("ur5")
    with pytest.raises(InvalidInput, match="locked_joints is empty"):
        reg.reduce("ur5", {})
