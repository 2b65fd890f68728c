"""Slow: mutated MJCF (random attributes, values and elements on the hand-written models) is
either refused by robodyn's own validation, naming the element, or builds in Pinocchio's parser
without a crash, a hang or a failure only Pinocchio noticed (which would be a validation hole).

Run with `pytest -m slow tests/service/test_mjcf_fuzz.py` (about 2 minutes).
"""

from __future__ import annotations

import random
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from service.errors import InvalidModel
from service.registry.build_process import build_isolated
from service.registry.mjcf_check import check_mjcf
from tests.service.mjcf_models import MULTI_JOINT_MJCF, TWINS

pytestmark = pytest.mark.slow

ATTRIBUTES = ["pos", "quat", "euler", "axisangle", "xyaxes", "zaxis", "size", "type", "fromto",
              "range", "axis", "mass", "diaginertia", "fullinertia", "class", "childclass",
              "name", "mesh", "density", "contype", "conaffinity", "group", "armature", "ref",
              "margin", "limited", "qpos", "angle", "eulerseq", "inertiafromgeom", "autolimits",
              "boundmass", "actuatorfrcrange", "model"]
VALUES = ["", "1", "1 2", "1 2 3", "0 0 0", "0 0 0 0", "-1", "abc", "1e308 1e308 1e308", "box",
          "mesh", "sphere", "capsule", "plane", "cylinder", "ellipsoid", "free", "ball", "slide",
          "hinge", "arm", "true", "false", "radian", "degree", "zyx", "1 0 0 0", "0 0 1 90",
          "1 2 3 4 5 6", "  ", "0", "1 1 1", "0.1 0.2 0.3 0.4 0.5 0.6 0.7", "link1", "torso",
          "-0.5 0.5", "1e-300", "NaN", "+.5e-3 1 1"]
TAGS = ["joint", "freejoint", "geom", "site", "inertial", "body", "default", "key", "keyframe",
        "compiler", "frame", "include"]
SEEDS = [t[0] for t in TWINS.values()] + [MULTI_JOINT_MJCF]
PINOCCHIO_ONLY = ("crashed", "could not build", "longer than")


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


def test_mutated_mjcf_is_refused_by_name_or_builds() -> None:
    rng = random.Random(20240607)
    outcomes = {"refused": 0, "built": 0, "refused by the model checks": 0}
    for _ in range(1500):
        text = mutate(rng.choice(SEEDS), rng)
        root_joint = rng.choice(["fixed", "fixed", "free-flyer", "planar"])
        try:
            check_mjcf(text, root_joint)
        except InvalidModel:
            outcomes["refused"] += 1
            continue
        try:
            model = build_isolated(text, root_joint, None, 60, description_format="mjcf")
        except InvalidModel as exc:
            assert not any(s in exc.detail for s in PINOCCHIO_ONLY), (exc.detail, text)
            outcomes["refused by the model checks"] += 1
            continue
        outcomes["built"] += 1
        for i in range(model.njoints):
            assert np.all(np.isfinite(model.inertias[i].toDynamicParameters())), text
    assert outcomes["refused"] > 300 and outcomes["built"] > 300, outcomes
