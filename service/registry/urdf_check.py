"""Validation of URDF text before any native parser sees it.

Pinocchio's URDF parser trusts its input: a mass of `nan` silently becomes a massless link, a zero
axis is accepted, and every structural error comes back as one generic message. This module parses
the text with a safe, bounded XML parser (`safe_xml`: no DTD, no entities, no external references,
element count and nesting capped) and checks structure and physics itself, so that errors name the
element at fault.

Physical findings (reported, and rejected by default for uploads; see API.md `inertia_check`), one
per link at most: the errors of `service.registry.inertia_rules` (`negative_principal_moment`,
`triangle_inequality`, `inertia_without_mass`), the rules every inertia check applies; the
message names the link, the numbers and, where one attribute off by a power of ten explains the
error, the corrected value.

Zero inertia (a point mass) is not a finding. Always rejected: malformed XML, a root element other
than <robot>, missing or duplicate names, unknown joint types, dangling parent/child links, several
roots, cycles, unparsable or non-finite numbers (in inertials, origins, axes, limits, dynamics,
mimics and visual/collision geometry), negative masses, zero joint axes, mimic joints naming no
joint, a moving joint whose subtree carries no mass (its column of M would be zero: M singular),
a joint or link named `universe` (Pinocchio's world joint and frame: it would be unreachable
by name), and descriptions over the caps of `Limits`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from xml.etree.ElementTree import Element

import numpy as np

from service.errors import InvalidModel
from service.registry.inertia_rules import (
    inertia_error,
    power_of_ten_fix,
    tensor,
)
from service.registry.mimic import mimic_problems
from service.registry.safe_xml import check_name_lengths, parse_bounded, read_numbers, shown
from service.settings import Settings

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
AXIS_TYPES = ("revolute", "continuous", "prismatic", "planar")
JOINT_NV = {"revolute": 1, "continuous": 1, "prismatic": 1, "fixed": 0, "floating": 6, "planar": 3}
RESERVED_NAME = "universe"  # Pinocchio's joint 0 and its frame: refused as a joint or link name


@dataclass(frozen=True)
class Finding:
    """A physical finding in a description, naming its element."""

    code: str
    element: str  # "link" or "joint"
    name: str
    message: str

    def as_dict(self) -> dict[str, str]:
        return {
            "code": self.code,
            "element": self.element,
            "name": self.name,
            "message": self.message,
        }


@dataclass
class URDFSummary:
    """What validation learned: robot name, counts, depth and physical findings."""

    robot_name: str
    links: int
    joints: int
    moving_joints: int
    depth: int
    findings: list[Finding] = field(default_factory=list)
    nv: int = 0  # velocity dimension of the description's own joints (without a root joint)


# The defaults are the settings' (ROBODYN_MAX_LINKS, ...): one place for each.
_SETTINGS = Settings.model_fields


@dataclass(frozen=True)
class Limits:
    """Caps that bound parse time and memory. The defaults admit every catalog robot (at most
    130 links, nv 101, kinematic depth 21, 3,851 XML elements, XML nesting 6) with a wide margin;
    `nv` matters most: a Pinocchio `Data` takes about 80·nv³ bytes (170 MB at nv = 128)."""

    max_links: int = _SETTINGS["max_links"].default
    max_nv: int = _SETTINGS["max_nv"].default
    max_depth: int = _SETTINGS["max_depth"].default
    max_elements: int = _SETTINGS["max_xml_elements"].default
    max_xml_depth: int = _SETTINGS["max_xml_depth"].default
    max_name_length: int = _SETTINGS["max_name_length"].default  # of robot, link, joint... names


def _numbers(text: str | None, count: int, what: str, default: str | None = None) -> list[float]:
    return read_numbers(text, count, what, default)


def _number(el: Element, attr: str, what: str, default: str | None = None) -> float:
    return _numbers(el.get(attr), 1, what, default)[0]


def _check_origin(el: Element | None, what: str) -> None:
    if el is None:
        return
    _numbers(el.get("xyz"), 3, f"{what} origin xyz", "0 0 0")
    _numbers(el.get("rpy"), 3, f"{what} origin rpy", "0 0 0")


_GEOMETRY = {
    "box": (("size", 3),),
    "cylinder": (("radius", 1), ("length", 1)),
    "sphere": (("radius", 1),),
    "capsule": (("radius", 1), ("length", 1)),
}


def _check_shapes(link: Element, name: str) -> None:
    """Visual and collision elements: the native parser reads their numbers too."""
    for tag in ("visual", "collision"):
        for el in link.findall(tag):
            what = f"link '{name}' {tag}"
            _check_origin(el.find("origin"), what)
            geometry = el.find("geometry")
            for shape in () if geometry is None else list(geometry):
                for attr, count in _GEOMETRY.get(shape.tag, ()):
                    _numbers(shape.get(attr), count, f"{what} {shape.tag} {attr}")
                if shape.tag == "mesh" and shape.get("scale") is not None:
                    _numbers(shape.get("scale"), 3, f"{what} mesh scale")
            material = el.find("material")
            color = None if material is None else material.find("color")
            if color is not None and color.get("rgba") is not None:
                _numbers(color.get("rgba"), 4, f"{what} material color rgba")


def _inertia_findings(
    link: str,
    inertia: np.ndarray,
    mass: float | None = None,
    attributes: dict[str, float] | None = None,
) -> list[Finding]:
    """At most one finding for a body's inertia (kg·m², about the centre of mass), by the rules
    of `inertia_rules` (`inertia_without_mass` where `mass` is given); with the `<inertia>`
    `attributes` as written, the message gives the power-of-ten slip that explains it."""
    error = inertia_error(1.0 if mass is None else mass, inertia)
    if error is None:
        return []
    message = f"link '{shown(link)}': {error.what}"
    fix = None if attributes is None or mass is None else power_of_ten_fix(mass, attributes)
    if fix is not None:
        message += f"; {fix[0]} = {fix[1]:.12g} (the written value times a power of ten) fixes it"
    return [Finding(error.code, "link", link, message)]


def _link_mass(link: Element, name: str, findings: list[Finding]) -> float:
    _check_shapes(link, name)
    inertial = link.find("inertial")
    if inertial is None:
        return 0.0
    label = shown(name)
    _check_origin(inertial.find("origin"), f"link '{label}' inertial")
    mass_el = inertial.find("mass")
    if mass_el is None:
        raise InvalidModel(f"link '{label}': <inertial> needs a <mass value=...>")
    mass = _number(mass_el, "value", f"link '{label}' mass value")
    if mass < 0:
        raise InvalidModel(f"link '{label}': mass {mass:.6g} kg is negative")
    inertia_el = inertial.find("inertia")
    if inertia_el is None:
        raise InvalidModel(f"link '{label}': <inertial> needs an <inertia> element")
    comps = {
        k: _number(inertia_el, k, f"link '{label}' inertia {k}")
        for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    }
    findings.extend(_inertia_findings(name, tensor(comps), mass, comps))
    return mass


def _check_joint(joint: Element, name: str, jtype: str) -> None:
    label = shown(name)
    _check_origin(joint.find("origin"), f"joint '{label}'")
    if jtype in AXIS_TYPES:
        axis_el = joint.find("axis")
        axis = _numbers(
            None if axis_el is None else axis_el.get("xyz"), 3, f"joint '{label}' axis xyz", "1 0 0"
        )
        if math.sqrt(sum(x * x for x in axis)) < 1e-9:
            raise InvalidModel(f"joint '{label}': axis is zero; a {jtype} joint needs a direction")
    limit = joint.find("limit")
    if limit is not None:
        for attr in ("lower", "upper", "effort", "velocity"):
            if limit.get(attr) is not None:
                _number(limit, attr, f"joint '{label}' limit {attr}")
    for tag in ("dynamics", "calibration", "safety_controller"):
        el = joint.find(tag)
        if el is not None:
            for attr, value in el.attrib.items():
                if attr in (
                    "damping",
                    "friction",
                    "rising",
                    "falling",
                    "soft_lower_limit",
                    "soft_upper_limit",
                    "k_position",
                    "k_velocity",
                ):
                    _numbers(value, 1, f"joint '{label}' {tag} {attr}")


def _check_parser_requirements(joint: Element, name: str, jtype: str) -> None:
    """What the native URDF parser (urdfdom) refuses with one generic message; named here."""
    label = shown(name)
    limit = joint.find("limit")
    if limit is None and jtype in ("revolute", "prismatic"):
        raise InvalidModel(
            f"joint '{label}': a {jtype} joint needs a <limit effort=... velocity=...> element"
        )
    if limit is not None:
        for attr in ("effort", "velocity"):
            if limit.get(attr) is None:
                raise InvalidModel(f"joint '{label}': <limit> needs an {attr} attribute")
    safety = joint.find("safety_controller")
    if safety is not None and safety.get("k_velocity") is None:
        raise InvalidModel(f"joint '{label}': <safety_controller> needs k_velocity")
    dynamics = joint.find("dynamics")
    if (
        dynamics is not None
        and dynamics.get("damping") is None
        and dynamics.get("friction") is None
    ):
        raise InvalidModel(f"joint '{label}': <dynamics> needs damping or friction")
    mimic = joint.find("mimic")
    if mimic is not None and not mimic.get("joint"):
        raise InvalidModel(f"joint '{label}': <mimic> needs a joint attribute")


def _names(elements: Iterable[Element], kind: str) -> dict[str, Element]:
    out: dict[str, Element] = {}
    for el in elements:
        name = el.get("name")
        if not name:
            raise InvalidModel(f"a <{kind}> element has no name")
        if name in out:
            raise InvalidModel(f"{kind} name '{shown(name)}' is used twice")
        out[name] = el
    return out


def parse_urdf(text: str, limits: Limits = Limits()) -> Element:
    """Parse URDF text safely (no DTDs, entities or external references; element count and
    nesting capped) and check that its root is <robot>."""
    root = parse_bounded(text, limits.max_elements, limits.max_xml_depth)
    if root.tag != "robot":
        raise InvalidModel(f"the root element is <{shown(root.tag)}>; a URDF needs <robot>")
    check_name_lengths(root, limits.max_name_length)
    return root


def check_urdf(text: str, limits: Limits = Limits(), *, lenient: bool = False) -> URDFSummary:
    """Validate URDF text: structure, finite numbers, physics and caps. Raises `InvalidModel`.

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
    for kind, names in (("joint", joints), ("link", links)):
        if RESERVED_NAME in names:
            raise InvalidModel(
                f"{kind} '{RESERVED_NAME}': the name is Pinocchio's own (its world joint and "
                f"frame), so that {kind} could not be found by name; rename it"
            )
    if len(links) > limits.max_links:
        raise InvalidModel(
            f"the description has {len(links)} links; the limit is "
            f"{limits.max_links} (ROBODYN_MAX_LINKS)"
        )

    children: dict[str, list[tuple[str, str]]] = {name: [] for name in links}
    mimics: dict[str, str] = {}  # joint → the joint it mimics (existing targets only)
    parent_of: dict[str, str] = {}
    child_of_joint: dict[str, str] = {}
    moving = nv = 0
    for jname, joint in joints.items():
        jtype = joint.get("type")
        label = shown(jname)
        if jtype not in JOINT_TYPES:
            raise InvalidModel(
                f"joint '{label}': type '{shown(jtype)}' is not one of {', '.join(JOINT_TYPES)}"
            )
        parent_el, child_el = joint.find("parent"), joint.find("child")
        parent = None if parent_el is None else parent_el.get("link")
        child = None if child_el is None else child_el.get("link")
        if not parent or not child:
            raise InvalidModel(f"joint '{label}': needs <parent link=...> and <child link=...>")
        for role, link in (("parent", parent), ("child", child)):
            if link not in links:
                raise InvalidModel(f"joint '{label}': {role} link '{shown(link)}' does not exist")
        if child in parent_of:
            raise InvalidModel(
                f"link '{shown(child)}' is the child of two joints "
                f"('{shown(parent_of[child])}' and '{label}')"
            )
        parent_of[child] = jname
        child_of_joint[jname] = child
        children[parent].append((jname, child))
        _check_joint(joint, jname, jtype)
        mimic = joint.find("mimic")
        if mimic is not None:
            target = mimic.get("joint")
            if target not in joints:
                tolerable(
                    Finding(
                        "dangling_mimic",
                        "joint",
                        jname,
                        f"joint '{label}': mimics joint '{shown(target)}', which "
                        "does not exist (the mimic is ignored)",
                    )
                )
            else:
                mimics[jname] = target
            for attr in ("multiplier", "offset"):
                if mimic.get(attr) is not None:
                    _number(mimic, attr, f"joint '{label}' mimic {attr}")
        if jtype != "fixed":
            moving += 1
            nv += JOINT_NV[jtype]
    for code, joint_name, message in mimic_problems(joints, mimics):
        tolerable(Finding(code, "joint", joint_name, message))
    if nv > limits.max_nv:
        raise InvalidModel(
            f"the description has nv = {nv} velocity coordinates ({moving} "
            f"moving joints); the limit is {limits.max_nv} (ROBODYN_MAX_NV)"
        )

    roots = [name for name in links if name not in parent_of]
    if len(roots) != 1:
        if not roots:
            raise InvalidModel("the kinematic graph has a cycle: every link has a parent joint")
        raise InvalidModel(
            f"the description has {len(roots)} root links "
            f"({', '.join(shown(r) for r in sorted(roots)[:5])}); a URDF tree "
            "has exactly one"
        )

    masses = {name: _link_mass(link, name, findings) for name, link in links.items()}

    # Iterative depth-first walk (no recursion: depth is attacker-controlled).
    order: list[tuple[str, int]] = []
    stack = [(roots[0], 0)]
    seen: set[str] = set()
    while stack:
        link, depth = stack.pop()
        if depth > limits.max_depth:
            raise InvalidModel(
                f"the kinematic chain is deeper than {limits.max_depth} links (ROBODYN_MAX_DEPTH)"
            )
        seen.add(link)
        order.append((link, depth))
        stack.extend((child, depth + 1) for _, child in children[link])
    if len(seen) != len(links):
        stray = sorted(set(links) - seen)[:5]
        raise InvalidModel(
            f"links {', '.join(shown(s) for s in stray)} are not connected to "
            f"the root '{shown(roots[0])}' (a cycle)"
        )

    subtree_mass = dict(masses)
    for link, _ in reversed(order):
        for _, child in children[link]:
            subtree_mass[link] += subtree_mass[child]
    for jname, joint in joints.items():
        if joint.get("type") != "fixed":
            child = child_of_joint[jname]
            if subtree_mass[child] <= 0.0:
                tolerable(
                    Finding(
                        "massless_subtree",
                        "joint",
                        jname,
                        f"joint '{shown(jname)}' moves link '{shown(child)}', whose subtree has no "
                        "mass: the mass matrix is singular",
                    )
                )
    for jname, joint in joints.items():
        _check_parser_requirements(joint, jname, joint.get("type", ""))
    return URDFSummary(
        robot_name=robot_name,
        links=len(links),
        joints=len(joints),
        moving_joints=moving,
        depth=max(d for _, d in order),
        findings=findings,
        nv=nv,
    )
