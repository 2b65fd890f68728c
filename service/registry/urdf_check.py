"""Validation of URDF text before any native parser sees it.

Pinocchio's URDF parser trusts its input: a mass of `nan` silently becomes a massless link, a zero
axis is accepted, and every structural error comes back as one generic message. This module parses
the text with a safe XML parser (no DTD, no entities, no external references) and checks structure
and physics itself, so that errors name the element at fault.

Physical findings (reported, and rejected by default for uploads; see API.md `inertia_check`):

- `negative_principal_moment`: an inertia tensor (kg·m², about the centre of mass) whose smallest
  principal moment is below −(1e-6 · largest moment + 1e-12); rounding-level negatives pass.
- `triangle_inequality`: principal moments with I_i + I_j < I_k − (1e-6 · trace + 1e-12).

Always rejected: malformed XML, a root element other than <robot>, missing or duplicate names,
unknown joint types, dangling parent/child links, several roots, cycles, non-finite or unparsable
numbers, negative masses, zero joint axes, mimic joints naming no joint, and a moving joint whose
subtree carries no mass (its column of M would be zero: M singular).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from xml.etree.ElementTree import Element

import defusedxml.ElementTree as SafeET
import numpy as np
from defusedxml import DefusedXmlException

from service.errors import InvalidModel

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
MOVING_AXIS_TYPES = ("revolute", "continuous", "prismatic")
NEGATIVE_REL_TOL = 1e-6
TRIANGLE_REL_TOL = 1e-6
ABS_TOL = 1e-12


@dataclass(frozen=True)
class Finding:
    """A physical finding in a description, naming its element."""

    code: str
    element: str  # "link" or "joint"
    name: str
    message: str

    def as_dict(self) -> dict[str, str]:
        return {"code": self.code, "element": self.element, "name": self.name,
                "message": self.message}


@dataclass
class URDFSummary:
    """What validation learned: robot name, counts, depth and physical findings."""

    robot_name: str
    links: int
    joints: int
    moving_joints: int
    depth: int
    findings: list[Finding] = field(default_factory=list)


@dataclass(frozen=True)
class Limits:
    """Caps that bound parse time and memory (defaults admit every catalog robot)."""

    max_links: int = 2000
    max_moving_joints: int = 300
    max_depth: int = 256
    max_elements: int = 200_000


def _numbers(text: str | None, count: int, what: str, default: str | None = None) -> list[float]:
    raw = text if text is not None else default
    if raw is None:
        raise InvalidModel(f"{what} is missing")
    parts = raw.split()
    if len(parts) != count:
        raise InvalidModel(f"{what} must have {count} numbers, found {len(parts)}")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise InvalidModel(f"{what} is not a number") from None
    if not all(math.isfinite(x) for x in values):
        raise InvalidModel(f"{what} must be finite")
    return values


def _number(el: Element, attr: str, what: str, default: str | None = None) -> float:
    return _numbers(el.get(attr), 1, what, default)[0]


def _check_origin(el: Element | None, what: str) -> None:
    if el is None:
        return
    _numbers(el.get("xyz"), 3, f"{what} origin xyz", "0 0 0")
    _numbers(el.get("rpy"), 3, f"{what} origin rpy", "0 0 0")


def _inertia_findings(link: str, tensor: np.ndarray) -> list[Finding]:
    moments = np.linalg.eigvalsh(tensor)
    shown = ", ".join(f"{m:.6g}" for m in moments)
    out = []
    largest = float(np.max(np.abs(moments)))
    if moments[0] < -(NEGATIVE_REL_TOL * largest + ABS_TOL):
        out.append(Finding(
            "negative_principal_moment", "link", link,
            f"link '{link}': inertia has a negative principal moment {moments[0]:.6g} kg·m² "
            f"(principal moments {shown})"))
    trace = float(np.sum(moments))
    tol = TRIANGLE_REL_TOL * abs(trace) + ABS_TOL
    a, b, c = moments
    if a + b < c - tol:
        excess = (c - a - b) / c * 100 if c > 0 else float("inf")
        out.append(Finding(
            "triangle_inequality", "link", link,
            f"link '{link}': principal moments {shown} kg·m² violate the triangle inequality "
            f"({a:.6g} + {b:.6g} < {c:.6g}, by {excess:.3g} %)"))
    return out


def _link_mass(link: Element, name: str, findings: list[Finding]) -> float:
    inertial = link.find("inertial")
    if inertial is None:
        return 0.0
    _check_origin(inertial.find("origin"), f"link '{name}' inertial")
    mass_el = inertial.find("mass")
    if mass_el is None:
        raise InvalidModel(f"link '{name}': <inertial> needs a <mass value=...>")
    mass = _number(mass_el, "value", f"link '{name}' mass value")
    if mass < 0:
        raise InvalidModel(f"link '{name}': mass {mass:.6g} kg is negative")
    inertia_el = inertial.find("inertia")
    if inertia_el is None:
        raise InvalidModel(f"link '{name}': <inertial> needs an <inertia> element")
    comps = {k: _number(inertia_el, k, f"link '{name}' inertia {k}")
             for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    tensor = np.array([
        [comps["ixx"], comps["ixy"], comps["ixz"]],
        [comps["ixy"], comps["iyy"], comps["iyz"]],
        [comps["ixz"], comps["iyz"], comps["izz"]],
    ])
    findings.extend(_inertia_findings(name, tensor))
    return mass


def _check_joint(joint: Element, name: str, jtype: str) -> None:
    _check_origin(joint.find("origin"), f"joint '{name}'")
    if jtype in MOVING_AXIS_TYPES:
        axis_el = joint.find("axis")
        axis = _numbers(None if axis_el is None else axis_el.get("xyz"), 3,
                        f"joint '{name}' axis xyz", "1 0 0")
        if math.sqrt(sum(x * x for x in axis)) < 1e-9:
            raise InvalidModel(f"joint '{name}': axis is zero; a {jtype} joint needs a direction")
    limit = joint.find("limit")
    if limit is not None:
        for attr in ("lower", "upper", "effort", "velocity"):
            if limit.get(attr) is not None:
                _number(limit, attr, f"joint '{name}' limit {attr}")
    for tag in ("dynamics", "calibration", "safety_controller"):
        el = joint.find(tag)
        if el is not None:
            for attr, value in el.attrib.items():
                if attr in ("damping", "friction", "rising", "falling", "soft_lower_limit",
                            "soft_upper_limit", "k_position", "k_velocity"):
                    _numbers(value, 1, f"joint '{name}' {tag} {attr}")


def _names(elements: Iterable[Element], kind: str) -> dict[str, Element]:
    out: dict[str, Element] = {}
    for el in elements:
        name = el.get("name")
        if not name:
            raise InvalidModel(f"a <{kind}> element has no name")
        if name in out:
            raise InvalidModel(f"{kind} name '{name}' is used twice")
        out[name] = el
    return out


def parse_urdf(text: str, limits: Limits = Limits()) -> Element:
    """Parse URDF text safely; refuse DTDs, entities and external references."""
    try:
        root = SafeET.fromstring(text, forbid_dtd=True, forbid_entities=True,
                                 forbid_external=True)
    except DefusedXmlException:
        raise InvalidModel("the XML has a DTD, entity or external reference; "
                           "these are refused") from None
    except SafeET.ParseError as exc:
        raise InvalidModel(f"the text is not well-formed XML ({exc})") from None
    except ValueError:
        raise InvalidModel("the text is not well-formed XML") from None
    if root.tag != "robot":
        raise InvalidModel(f"the root element is <{root.tag}>; a URDF needs <robot>")
    count = sum(1 for _ in root.iter())
    if count > limits.max_elements:
        raise InvalidModel(f"the description has {count} XML elements; "
                           f"the limit is {limits.max_elements}")
    return root


def check_urdf(text: str, limits: Limits = Limits(), *, lenient: bool = False) -> URDFSummary:
    """Validate URDF text: structure, finite numbers and physics. Raises `InvalidModel`.

    `lenient=True` (trusted catalog files) reports a dangling mimic target and a massless moving
    subtree as findings instead of rejecting them: real descriptions contain both.
    """
    findings: list[Finding] = []

    def tolerable(finding: Finding) -> None:
        if not lenient:
            raise InvalidModel(finding.message)
        findings.append(finding)

    root = parse_urdf(text, limits)
    robot_name = root.get("name")
    if not robot_name:
        raise InvalidModel("the <robot> element has no name attribute")
    links = _names(root.findall("link"), "link")
    joints = _names(root.findall("joint"), "joint")
    if not links:
        raise InvalidModel("the description has no <link>")
    if len(links) > limits.max_links:
        raise InvalidModel(f"the description has {len(links)} links; "
                           f"the limit is {limits.max_links}")

    children: dict[str, list[tuple[str, str]]] = {name: [] for name in links}
    parent_of: dict[str, str] = {}
    child_of_joint: dict[str, str] = {}
    moving = 0
    for jname, joint in joints.items():
        jtype = joint.get("type")
        if jtype not in JOINT_TYPES:
            raise InvalidModel(f"joint '{jname}': type '{jtype}' is not one of "
                               f"{', '.join(JOINT_TYPES)}")
        parent_el, child_el = joint.find("parent"), joint.find("child")
        parent = None if parent_el is None else parent_el.get("link")
        child = None if child_el is None else child_el.get("link")
        if not parent or not child:
            raise InvalidModel(f"joint '{jname}': needs <parent link=...> and <child link=...>")
        for role, link in (("parent", parent), ("child", child)):
            if link not in links:
                raise InvalidModel(f"joint '{jname}': {role} link '{link}' does not exist")
        if child in parent_of:
            raise InvalidModel(f"link '{child}' is the child of two joints "
                               f"('{parent_of[child]}' and '{jname}')")
        parent_of[child] = jname
        child_of_joint[jname] = child
        children[parent].append((jname, child))
        _check_joint(joint, jname, jtype)
        mimic = joint.find("mimic")
        if mimic is not None:
            target = mimic.get("joint")
            if target not in joints:
                tolerable(Finding("dangling_mimic", "joint", jname,
                                  f"joint '{jname}': mimics joint '{target}', which does not "
                                  "exist (the mimic is ignored)"))
            for attr in ("multiplier", "offset"):
                if mimic.get(attr) is not None:
                    _number(mimic, attr, f"joint '{jname}' mimic {attr}")
        if jtype != "fixed":
            moving += 1
    if moving > limits.max_moving_joints:
        raise InvalidModel(f"the description has {moving} moving joints; "
                           f"the limit is {limits.max_moving_joints}")

    roots = [name for name in links if name not in parent_of]
    if len(roots) != 1:
        if not roots:
            raise InvalidModel("the kinematic graph has a cycle: every link has a parent joint")
        raise InvalidModel(f"the description has {len(roots)} root links "
                           f"({', '.join(sorted(roots)[:5])}); a URDF tree has exactly one")

    masses = {name: _link_mass(link, name, findings) for name, link in links.items()}

    # Iterative depth-first walk (no recursion: depth is attacker-controlled).
    order: list[tuple[str, int]] = []
    stack = [(roots[0], 0)]
    seen: set[str] = set()
    while stack:
        link, depth = stack.pop()
        if depth > limits.max_depth:
            raise InvalidModel(f"the kinematic chain is deeper than {limits.max_depth} links")
        seen.add(link)
        order.append((link, depth))
        stack.extend((child, depth + 1) for _, child in children[link])
    if len(seen) != len(links):
        stray = sorted(set(links) - seen)[:5]
        raise InvalidModel(f"links {', '.join(stray)} are not connected to the root "
                           f"'{roots[0]}' (a cycle)")

    subtree_mass = dict(masses)
    for link, _ in reversed(order):
        for _, child in children[link]:
            subtree_mass[link] += subtree_mass[child]
    for jname, joint in joints.items():
        if joint.get("type") != "fixed":
            child = child_of_joint[jname]
            if subtree_mass[child] <= 0.0:
                tolerable(Finding(
                    "massless_subtree", "joint", jname,
                    f"joint '{jname}' moves link '{child}', whose subtree has no mass: "
                    "the mass matrix is singular"))
    return URDFSummary(robot_name=robot_name, links=len(links), joints=len(joints),
                       moving_joints=moving, depth=max(d for _, d in order), findings=findings)
