"""Slow: mutated MJCF (random attributes, values and elements on the hand-written models) is
either refused with a message (MuJoCo's own or robodyn's) or builds, in the isolated builder,
without a crash, a hang or a failure without a reason; what builds has MuJoCo's mass matrix and
bias forces at a random state.

Run with `pytest -m slow tests/service/registry/test_mjcf_fuzz.py` (about 2 minutes).
"""

from __future__ import annotations

import random
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from service.errors import InvalidModel
from service.registry.build_process import build_isolated
from tests.service.registry.mjcf_models import MULTI_JOINT_MJCF, TWINS
from tests.service.registry.mjcf_reference import pinocchio_q, random_states, relative_error

pytestmark = pytest.mark.slow

ATTRIBUTES = [
    "pos",
    "quat",
    "euler",
    "axisangle",
    "xyaxes",
    "zaxis",
    "size",
    "type",
    "fromto",
    "range",
    "axis",
    "mass",
    "diaginertia",
    "fullinertia",
    "class",
    "childclass",
    "name",
    "mesh",
    "density",
    "contype",
    "conaffinity",
    "group",
    "armature",
    "ref",
    "margin",
    "limited",
    "qpos",
    "angle",
    "eulerseq",
    "inertiafromgeom",
    "autolimits",
    "boundmass",
    "actuatorfrcrange",
    "model",
]
VALUES = [
    "",
    "1",
    "1 2",
    "1 2 3",
    "0 0 0",
    "0 0 0 0",
    "-1",
    "abc",
    "1e308 1e308 1e308",
    "box",
    "mesh",
    "sphere",
    "capsule",
    "plane",
    "cylinder",
    "ellipsoid",
    "free",
    "ball",
    "slide",
    "hinge",
    "arm",
    "true",
    "false",
    "radian",
    "degree",
    "zyx",
    "1 0 0 0",
    "0 0 1 90",
    "1 2 3 4 5 6",
    "  ",
    "0",
    "1 1 1",
    "0.1 0.2 0.3 0.4 0.5 0.6 0.7",
    "link1",
    "torso",
    "-0.5 0.5",
    "1e-300",
    "NaN",
    "+.5e-3 1 1",
]
TAGS = [
    "joint",
    "freejoint",
    "geom",
    "site",
    "inertial",
    "body",
    "default",
    "key",
    "keyframe",
    "compiler",
    "frame",
    "include",
]
SEEDS = [t[0] for t in TWINS.values()] + [MULTI_JOINT_MJCF]
NO_REASON = ("crashed", "could not build", "longer than", "ended without an answer")


def mutate(text: str, rng: random.Random) -> str:
    root = ET.fromstring(text)
    elements = list(root.iter())
    for _ in range(rng.randint(1, 3)):
        el = rng.choice(elements)
        op = rng.random()
        if op < 0.6:
            el.set(rng.choice(ATTRIBUTES), rng.choice(VALUES))
        elif op < 0.75 and el.attrib:
            del el.attrib[rng.choice(list(el.attrib))]
        elif op < 0.9:
            ET.SubElement(el, rng.choice(TAGS), {rng.choice(ATTRIBUTES): rng.choice(VALUES)})
        else:
            for parent in elements:
                if el in list(parent):
                    parent.remove(el)
                    break
    return ET.tostring(root, encoding="unicode")


def test_mutated_mjcf_is_refused_with_a_reason_or_builds_as_mujoco() -> None:
    import mujoco
    import pinocchio as pin

    rng = random.Random(20240607)
    outcomes = {"refused": 0, "built": 0}
    for _ in range(400):
        text = mutate(rng.choice(SEEDS), rng)
        try:
            model = build_isolated(text, "fixed", None, 60, description_format="mjcf")
        except InvalidModel as exc:
            assert not any(s in exc.detail for s in NO_REASON), (exc.detail, text)
            outcomes["refused"] += 1
            continue
        outcomes["built"] += 1
        mj = mujoco.MjModel.from_xml_string(text)
        data = model.createData()
        for qpos, qvel, M, bias in random_states(mj, np.random.default_rng(0), 1):
            q = pinocchio_q(mj, qpos)
            M_pin = pin.crba(model, data, q)
            M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
            assert relative_error(M_pin, M) < 1e-9, text
            assert relative_error(pin.nonLinearEffects(model, data, q, qvel), bias) < 1e-9, text
    # MuJoCo's schema refuses most mutations (unknown attributes and elements)
    assert outcomes["refused"] > 100 and outcomes["built"] > 20, outcomes
