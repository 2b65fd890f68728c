"""The MJCF text Pinocchio is given: every body and joint named, one joint per body, a model
name (Pinocchio refuses a <mujoco> with attributes but no `model`; MuJoCo does not).

Pinocchio turns a body with several joints into one composite joint, and (measured on 4.1) its
Coriolis matrix of composite joints is wrong: C v differs from the nonlinear effects minus
gravity and Ṁ ≠ C + Cᵀ. So, before parsing, such a body is split into a chain: the first joints
each get their own massless body, named `<body>#1`, `<body>#2`, ..., at the body's pose, and the
last joint keeps the body, its name, inertia, geoms, sites and children. Joint positions and axes
are in the body frame in MuJoCo and stay so (every body of the chain has the body's frame at
q = 0), and each joint moves the ones after it, as in MuJoCo: the dynamics are the same, and
every joint keeps its own name, type, limits and armature.

Unnamed bodies and joints are first given the names Pinocchio would give them (`<parent>Bis`,
`<body>Joint_<k>`, `<body>_free`), so the split does not change any name.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from xml.etree.ElementTree import Element

from service.registry.mjcf_attributes import chain_body_name
from service.registry.mjcf_check import parse_mjcf

PLACEMENT = ("pos", "quat", "axisangle", "euler", "xyaxes", "zaxis")
JOINTS = ("joint", "freejoint")


def _name_everything(top: Element) -> None:
    stack = [(top, "")]
    while stack:
        body, parent = stack.pop()
        name = body.get("name") or parent + "Bis"
        body.set("name", name)
        joints = [c for c in body if c.tag in JOINTS]
        for k, joint in enumerate(joints):
            if joint.get("name") is None:
                joint.set("name", f"{name}_free" if joint.tag == "freejoint"
                          else f"{name}Joint_{k}")
        stack.extend((child, name) for child in body if child.tag == "body")


def _split(body: Element) -> None:
    joints = [c for c in body if c.tag in JOINTS]
    if len(joints) < 2:
        return
    name = body.get("name", "")
    others = [c for c in body if c.tag not in JOINTS]
    kept = {k: v for k, v in body.attrib.items() if k not in PLACEMENT}
    for child in list(body):
        body.remove(child)
    # `body` becomes the outermost link of the chain (it keeps the pose and childclass)
    body.attrib = {k: v for k, v in body.attrib.items() if k in PLACEMENT or k == "childclass"}
    outer = body
    for index, joint in enumerate(joints[:-1], start=1):
        outer.set("name", chain_body_name(name, index))
        outer.append(joint)
        ET.SubElement(outer, "inertial", {"pos": "0 0 0", "mass": "0",
                                          "diaginertia": "0 0 0"})
        inner = ET.SubElement(outer, "body")
        outer = inner
    outer.attrib.update(kept)
    outer.set("name", name)
    outer.append(joints[-1])
    outer.extend(others)


def pinocchio_text(text: str) -> str:
    """The MJCF text to give Pinocchio for validated `text` (see the module docstring)."""
    root = parse_mjcf(text)
    root.set("model", root.get("model") or "mjcf")  # Pinocchio needs it once <mujoco> has any
    world = root.find("worldbody")
    tops = [] if world is None else [c for c in world if c.tag == "body"]
    if not tops:
        return ET.tostring(root, encoding="unicode")
    _name_everything(tops[0])
    stack = [tops[0]]
    while stack:
        body = stack.pop()
        children = [c for c in body if c.tag == "body"]
        _split(body)
        stack.extend(children)
    return ET.tostring(root, encoding="unicode")
