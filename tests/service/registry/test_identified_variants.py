"""Variants carrying identified values (service.registry.variants.Fitted): the parameters
replace the parent's inertias, the friction follows the joints by name into further variants,
and the record rebuilds both."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.dynamics.identification import inertial_parameters
from service.registry import Registry
from service.registry.variants import Fitted


@pytest.fixture
def registry(tmp_path):
    registry = Registry(tmp_path, ["ur5"])
    registry.load()
    return registry


def _fitted(model) -> Fitted:
    pi = inertial_parameters(model) * 1.1
    friction = tuple(
        (str(model.names[j]), 0.1 * j, 0.2, -0.01 * j) for j in range(1, model.njoints)
    )
    return Fitted(tuple(float(x) for x in pi), friction)


def test_identified_values_and_a_reduction_of_them(registry, tmp_path):
    ur5 = registry.get("ur5")
    fitted = _fitted(ur5.model)
    robot, created = registry.variant("ur5", fitted=fitted, name="ur5 identified")
    assert created and robot.id.startswith("v-") and robot.parent == "ur5"
    np.testing.assert_allclose(inertial_parameters(robot.model), fitted.inertial_parameters)
    np.testing.assert_allclose(robot.friction["coulomb"], [0.1 * j for j in range(1, 7)])
    assert registry.variant("ur5", fitted=fitted)[1] is False  # the same values, stored
    # a reduction of it keeps the friction of the joints that remain
    reduced, _ = registry.variant(robot.id, locked_joints={"shoulder_pan_joint": 0.0})
    assert reduced.nv == 5
    np.testing.assert_allclose(reduced.friction["coulomb"], [0.1 * j for j in range(2, 7)])
    assert reduced.info()["friction"][0]["joint"] == "shoulder_lift_joint"
    # both rebuilt from their records by another registry on the same store
    again = Registry(tmp_path, ["ur5"])
    again.load()
    for stored in (robot, reduced):
        rebuilt = again.get(stored.id)
        assert rebuilt.info()["friction"] == stored.info()["friction"]
        q = pin.neutral(stored.model) + 0.3
        np.testing.assert_allclose(
            pin.crba(rebuilt.model, rebuilt.model.createData(), q),
            pin.crba(stored.model, stored.model.createData(), q),
        )
