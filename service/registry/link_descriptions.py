"""What a URDF says about each link's mass and shape: its `<inertial>` as written and its
collision and visual geometry, read in pure Python (`safe_xml`, bounded) for the model check.

A link's inertial is in the link frame: mass m (kg), centre of mass c (m, the `<origin xyz>`),
and the rotational inertia about c in the link axes, I = R I' Rᵀ (kg·m²), where I' is the
`<inertia>` as written (its six `attributes`, kept for suggestions) in the axes of the
`<origin rpy>` (R = Rz(yaw) Ry(pitch) Rx(roll)). A link without `<inertial>` has mass 0 and
inertia 0. A geometry element is `(placement rotation 3×3, translation [3], geometry)` with
`geometry` as `service.registry.visuals` gives it (a mesh by its asset key and `scale`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any
from xml.etree.ElementTree import Element

import numpy as np

from service.errors import InvalidModel
from service.registry.inertia_rules import ATTRIBUTES, tensor
from service.registry.safe_xml import parse_bounded, read_numbers
from service.registry.visuals import MAX_DEPTH, MAX_ELEMENTS, rpy_matrix, shape_geometry

ShapeElement = tuple[np.ndarray, np.ndarray, dict[str, Any]]
"""(rotation 3×3, translation [3] m, geometry) of one collision or visual element."""


@dataclass(frozen=True)
class LinkDescription:
    """One link of a description: its inertial in the link frame and its geometry."""

    name: str
    mass: float  # kg
    center_of_mass: np.ndarray  # (3,) m, link frame
    inertia: np.ndarray  # (3, 3) kg·m², about the centre of mass, link axes
    attributes: dict[str, float] | None  # the <inertia> as written (its own axes); None: none
    moves: bool  # some joint between it and the world moves (the root joint counted)
    collision: list[ShapeElement] = field(default_factory=list)
    visual: list[ShapeElement] = field(default_factory=list)


def _placement(el: Element | None) -> tuple[np.ndarray, np.ndarray]:
    xyz = read_numbers(None if el is None else el.get("xyz"), 3, "origin xyz", "0 0 0")
    rpy = read_numbers(None if el is None else el.get("rpy"), 3, "origin rpy", "0 0 0")
    return np.array(rpy_matrix(*rpy)), np.array(xyz, dtype=float)


def _shapes(link: Element, tag: str) -> list[ShapeElement]:
    out: list[ShapeElement] = []
    for el in link.findall(tag):
        geometry_el = el.find("geometry")
        try:
            geometry = None if geometry_el is None else shape_geometry(geometry_el)
            if geometry is not None:
                rotation, translation = _placement(el.find("origin"))
                out.append((rotation, translation, geometry))
        except InvalidModel:
            continue  # unreadable numbers: that element is not counted
    return out


def _inertial(link: Element) -> tuple[float, np.ndarray, np.ndarray, dict[str, float] | None]:
    inertial = link.find("inertial")
    if inertial is None:
        return 0.0, np.zeros(3), np.zeros((3, 3)), None
    rotation, com = _placement(inertial.find("origin"))
    mass_el = inertial.find("mass")
    mass = read_numbers(None if mass_el is None else mass_el.get("value"), 1, "mass", "0")[0]
    inertia_el = inertial.find("inertia")
    attributes = {
        k: read_numbers(None if inertia_el is None else inertia_el.get(k), 1, k, "0")[0]
        for k in ATTRIBUTES
    }
    return mass, com, rotation @ tensor(attributes) @ rotation.T, attributes


def link_descriptions(urdf_text: str, root_joint: str = "fixed") -> list[LinkDescription]:
    """Every link of a URDF (document order). `root_joint` is the joint the robot is mounted
    on the world with ("fixed", "free-flyer", "planar"): whether its root link moves."""
    root = parse_bounded(urdf_text, MAX_ELEMENTS, MAX_DEPTH)
    parent_joint: dict[str, tuple[str, str]] = {}  # child link → (parent link, joint type)
    for joint in root.findall("joint"):
        parent_el, child_el = joint.find("parent"), joint.find("child")
        if parent_el is not None and child_el is not None:
            parent_joint[child_el.get("link", "")] = (
                parent_el.get("link", ""),
                joint.get("type", "fixed"),
            )
    out = []
    for link in root.findall("link"):
        name = link.get("name", "")
        mass, com, inertia, attributes = _inertial(link)
        out.append(
            LinkDescription(
                name=name,
                mass=mass,
                center_of_mass=com,
                inertia=inertia,
                attributes=attributes,
                moves=_moves(name, parent_joint, root_joint),
                collision=_shapes(link, "collision"),
                visual=_shapes(link, "visual"),
            )
        )
    return out


def _moves(link: str, parent_joint: dict[str, tuple[str, str]], root_joint: str) -> bool:
    seen: set[str] = set()
    while link in parent_joint and link not in seen:
        seen.add(link)
        link, kind = parent_joint[link]
        if kind != "fixed":
            return True
    return root_joint != "fixed"
