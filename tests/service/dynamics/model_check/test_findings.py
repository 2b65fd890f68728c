"""Left/right twins: names that differ only in a left/right marker word, as the catalog's
humanoids and arms write them, and not a quadruped's leg prefixes; twins disagree when their
masses are equal and a principal moment differs by more than half."""

from __future__ import annotations

import numpy as np
import pytest

from service.dynamics.model_check.findings import mirror_finding, twins
from service.registry.link_descriptions import LinkDescription


@pytest.mark.parametrize(
    ("left", "right"),
    [
        ("l_hip_link", "r_hip_link"),  # icub
        ("LHipYawLink", "RHipYawLink"),  # romeo
        ("arm_left_1_link", "arm_right_1_link"),  # talos
        ("leg_L_knee", "leg_R_knee"),
        ("left-foot", "right-foot"),
        ("hand.l", "hand.r"),
    ],
)
def test_names_differing_in_a_left_right_word_are_twins(left, right):
    assert twins([left, "torso", right]) == [(left, right)]


@pytest.mark.parametrize(
    "names",
    [
        ["LF_HIP", "RF_HIP"],  # a quadruped's legs: LF is not a marker word
        ["l_hip", "l_hip_2"],
        ["left_arm", "left_arm"],
        ["lleg", "rleg"],
        ["l_arm_l", "r_arm_l"],  # every marker swaps side for side
    ],
)
def test_other_names_are_not_twins(names):
    assert twins(names) == []


def _link(name: str, mass: float, moments: list[float]) -> LinkDescription:
    return LinkDescription(name, mass, np.zeros(3), np.diag(moments), None, True)


def test_twins_disagree_with_equal_masses_and_a_moment_more_than_half_off():
    a = _link("l_leg", 2.0, [0.01, 0.02, 0.025])
    assert mirror_finding(a, _link("r_leg", 2.0, [0.01, 0.02, 0.025])) is None
    assert mirror_finding(a, _link("r_leg", 2.0, [0.0051, 0.02, 0.025])) is None  # 49 % off
    found = mirror_finding(a, _link("r_leg", 2.0, [0.0049, 0.02, 0.025]))  # 51 % off
    assert found is not None and found.code == "mirror_asymmetry" and found.link == "l_leg"
    assert "r_leg" in found.message
    assert mirror_finding(a, _link("r_leg", 2.1, [0.0, 0.0, 0.0])) is None  # not meant as twins
