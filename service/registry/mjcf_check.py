"""Validation of MJCF (MuJoCo XML) text before Pinocchio's MJCF parser sees it.

Measured on the installed Pinocchio (4.1): its MJCF parser reads unparsable numbers as
uninitialised memory, recurses (and copies) per nesting level, silently drops all but the first
top-level body and bodies whose generated names collide, ignores the placement of a joint-less
top body, scales slide-joint ranges by π/180 in degree mode, and gives every structural error the
same generic message. This module parses the text with a safe XML parser (no DTD, no entities, no
external references) and checks what Pinocchio would otherwise get wrong, naming the element.

Always rejected: malformed XML, a root other than <mujoco>, <include> (no file is ever read),
unknown or repeated top-level sections, nesting deeper than the caps, a <worldbody> without
exactly one top body, unsupported elements (<frame>, <replicate>, <composite>, ...), numbers that
are not finite plain decimals or not as many as the attribute takes, duplicate or reserved names,
unknown joint or geom types, free joints below the top body or sharing a body,
a joint `ref` other than 0, zero axes, negative masses, densities, armatures or sizes, inertials
without mass or inertia, bodies whose inertia would come from mesh geoms (meshes are not read),
keyframes whose length is not nq, and compiler options Pinocchio ignores but that change the
model (`coordinate="global"`, `autolimits="false"`, `settotalmass`, `balanceinertia`, fixed-axis
`eulerseq` letters X, Y, Z).

Physical findings (rejected unless `inertia_check` is "warn"): the same inertia findings as
URDF uploads (`negative_principal_moment`, `triangle_inequality`), per body. Notes (always only
warnings): ignored equality constraints and an ignored translation of a joint-less top body.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from xml.etree.ElementTree import Element

import defusedxml.ElementTree as SafeET
from defusedxml import DefusedXmlException

from service.errors import InvalidModel
from service.registry.mjcf_attributes import (
    check_numbers,
    default_classes,
    numbers,
    rotation_given,
    shown,
)
from service.registry.mjcf_tree import BodyTree, walk_bodies
from service.registry.safe_xml import check_name_lengths
from service.registry.urdf_check import Finding, Limits

SECTIONS = ("compiler", "option", "size", "visual", "statistic", "default", "custom", "asset",
            "worldbody", "contact", "deformable", "equality", "tendon", "actuator", "sensor",
            "keyframe")
SINGLE_SECTIONS = ("compiler", "default", "asset", "worldbody", "keyframe", "equality")
WORLD_CHILDREN = ("body", "geom", "site", "camera", "light")
ROOT_NQ = {"fixed": 0, "free-flyer": 7, "planar": 4}
ROOT_NV = {"fixed": 0, "free-flyer": 6, "planar": 3}
DEFAULT_LIMITS = Limits()
XML_DEPTH_MARGIN = 8  # <mujoco>, <worldbody>, <default> levels above the body tree


@dataclass
class MJCFSummary:
    """What validation learned, and what building the model needs to know."""

    robot_name: str
    bodies: int
    moving_joints: int
    depth: int
    root_joint: str  # as served: "free-flyer" when the top body has a free joint
    added_root_joint: str  # the joint robodyn adds above the top body ("fixed": none)
    angle_in_degrees: bool
    nq: int
    findings: list[Finding] = field(default_factory=list)  # physical: reject or warn
    notes: list[Finding] = field(default_factory=list)  # always warnings


def parse_mjcf(text: str, limits: Limits = DEFAULT_LIMITS) -> Element:
    """Parse MJCF text safely; refuse DTDs, entities, external references and deep nesting."""
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
    if root.tag != "mujoco":
        raise InvalidModel(f"the root element is <{shown(str(root.tag))}>; an MJCF needs <mujoco>")
    check_name_lengths(root, limits.max_name_length)
    count = sum(1 for _ in root.iter())
    if count > limits.max_elements:
        raise InvalidModel(f"the description has {count} XML elements; "
                           f"the limit is {limits.max_elements}")
    stack = [(root, 1)]
    while stack:
        el, depth = stack.pop()
        if depth > limits.max_depth + XML_DEPTH_MARGIN:
            name = el.get("name") or el.get("class")
            raise InvalidModel(f"<{shown(str(el.tag))}>{f' {shown(name)!r}' if name else ''} "
                               f"is nested deeper than {limits.max_depth + XML_DEPTH_MARGIN} XML "
                               "levels")
        stack.extend((child, depth + 1) for child in el)
    return root


def _label(el: Element, parent: str) -> str:
    name = el.get("name") or el.get("class")
    kind = f"<{shown(str(el.tag))}>"
    return f"{kind} '{shown(name)}'" if name else f"a {kind} in {parent}"


def _check_all_numbers(root: Element) -> None:
    stack: list[tuple[Element, str | None]] = [(root, None)]
    while stack:
        el, parent = stack.pop()
        label = "<mujoco>" if parent is None else _label(el, parent)
        if el.tag == "include":
            raise InvalidModel(f"{label}: <include> is refused; send one self-contained file")
        check_numbers(el, label)
        stack.extend((child, label) for child in el)


def _sections(root: Element) -> dict[str, Element]:
    out: dict[str, Element] = {}
    for child in root:
        tag = str(child.tag)
        if tag not in SECTIONS:
            raise InvalidModel(f"<mujoco> has a <{shown(tag)}> section, which robodyn does not "
                               f"support (known: {', '.join(SECTIONS)})")
        if tag in out and tag in SINGLE_SECTIONS:
            raise InvalidModel(f"<mujoco> has more than one <{tag}> section; merge them into one "
                               "(Pinocchio reads only the first)")
        out.setdefault(tag, child)
    return out


def _compiler(el: Element | None) -> tuple[bool, str, bool]:
    """(angles in degrees?, inertiafromgeom, bounds on mass or inertia?) from <compiler>;
    refuse options Pinocchio ignores."""
    if el is None:
        return True, "auto", False
    angle = el.get("angle", "degree")
    if angle not in ("degree", "radian"):
        raise InvalidModel("<compiler> angle must be 'degree' or 'radian'")
    refused = {"coordinate": ("local",), "autolimits": ("true",), "balanceinertia": ("false",),
               "inertiafromgeom": ("true", "false", "auto")}
    for attr, allowed in refused.items():
        value = el.get(attr)
        if value is not None and value not in allowed:
            raise InvalidModel(f"<compiler> {attr}='{shown(value)}' is not supported "
                               f"(supported: {', '.join(allowed)})")
    if el.get("settotalmass") is not None:
        raise InvalidModel("<compiler> settotalmass is not supported: Pinocchio would ignore it")
    seq = el.get("eulerseq", "xyz")
    if len(seq) != 3 or any(c not in "xyz" for c in seq):
        raise InvalidModel("<compiler> eulerseq must be 3 letters among x, y, z (rotating axes; "
                           "Pinocchio reads the fixed-axis X, Y, Z as rotating ones)")
    bounds = [float(el.get(attr, "0")) for attr in ("boundmass", "boundinertia")]
    if min(bounds) < 0:
        raise InvalidModel("<compiler> boundmass and boundinertia must not be negative")
    return angle == "degree", el.get("inertiafromgeom", "auto"), max(bounds) > 0




def _root(tree: BodyTree, root_joint: str) -> tuple[str, str, list[Finding]]:
    """(root joint as served, joint robodyn adds, notes) from the top body and `root_joint`.

    A free joint on the top body is its own root: `root_joint` "fixed" (the default) or
    "free-flyer" both mean it, and the model is served as "free-flyer". A top body without a
    joint gets `root_joint` added above it. A top body with other joints hangs from the world.
    """
    kinds = [k for _, k in tree.top_joints]
    top = f"the top body '{shown(tree.top_body)}'"
    if "free" in kinds:
        if root_joint == "planar":
            raise InvalidModel(f"root_joint 'planar' cannot be added: {top} has a free joint, "
                               "which is already its root")
        return "free-flyer", "fixed", []
    if kinds:
        if root_joint != "fixed":
            raise InvalidModel(
                f"root_joint '{root_joint}' cannot be added: {top} has joint "
                f"'{shown(tree.top_joints[0][0])}' (Pinocchio would ignore the root joint); give "
                "the MJCF a top body without joints, or a <freejoint/> on its top body")
        return "fixed", "fixed", []
    if root_joint == "free-flyer":
        return root_joint, root_joint, []
    if tree.top_rotated:
        raise InvalidModel(f"{top} has no joint and an orientation, which Pinocchio ignores (it "
                           "would change the direction of gravity); rotate its child bodies "
                           "instead")
    notes = []
    if tree.top_translated:
        notes.append(Finding("ignored_root_placement", "body", tree.top_body,
                             f"{top} has no joint; Pinocchio ignores its position, so the robot "
                             "is attached to the world at the origin (the dynamics are the same)"))
    return root_joint, root_joint, notes


def _keyframes(section: Element | None, nq: int, added: str) -> None:
    for key in [] if section is None else section:
        if key.tag != "key" or key.get("name") is None or key.get("qpos") is None:
            continue  # Pinocchio ignores keys without a name or qpos
        qpos = numbers(key.get("qpos", ""), "keyframe qpos")
        if len(qpos) != nq:
            extra = (f" (including the {ROOT_NQ[added]} of the root joint)"
                     if added != "fixed" else "")
            raise InvalidModel(f"keyframe '{shown(key.get('name', ''))}': qpos has {len(qpos)} "
                               f"numbers; the model has nq = {nq}{extra}")


def _equality_notes(section: Element | None) -> list[Finding]:
    notes = []
    for eq in [] if section is None else section:
        name = eq.get("name") or f"{eq.get('body1') or eq.get('site1') or '?'}"
        notes.append(Finding(
            "ignored_equality", "equality", shown(name),
            f"<{shown(str(eq.tag))}> equality '{shown(name)}' is not part of the model: robodyn "
            "computes the dynamics of the open kinematic tree"))
    return notes


def check_mjcf(text: str, root_joint: str = "fixed",
               limits: Limits = DEFAULT_LIMITS) -> MJCFSummary:
    """Validate MJCF text: structure, finite numbers and physics. Raises `InvalidModel`."""
    root = parse_mjcf(text, limits)
    _check_all_numbers(root)
    sections = _sections(root)
    degrees, inertia_from_geom, bounded = _compiler(sections.get("compiler"))
    classes = default_classes(sections.get("default"))
    world = sections.get("worldbody")
    if world is None:
        raise InvalidModel("<mujoco> has no <worldbody>")
    for child in world:
        if child.tag not in WORLD_CHILDREN:
            raise InvalidModel(f"<worldbody>: <{shown(str(child.tag))}> is not supported "
                               f"(supported: {', '.join(WORLD_CHILDREN)})")
        if child.tag in ("geom", "site"):
            rotation_given(classes.effective(child, None, "<worldbody>"),
                           f"a <{child.tag}> of <worldbody>")
    tops = [c for c in world if c.tag == "body"]
    if len(tops) != 1:
        raise InvalidModel(f"<worldbody> has {len(tops)} top-level bodies; robodyn serves one "
                           "tree (Pinocchio reads only the first): put them under one body")
    tree = walk_bodies(tops[0], classes, limits, inertia_from_geom)
    if tree.split_bodies and bounded:
        raise InvalidModel("<compiler> boundmass/boundinertia cannot be combined with bodies "
                           "that have several joints (served as chains of massless bodies)")
    served, added, notes = _root(tree, root_joint)
    nq = tree.nq + ROOT_NQ[added]
    max_nv = getattr(limits, "max_nv", None)
    if max_nv is not None and tree.nv + ROOT_NV[added] > max_nv:
        raise InvalidModel(f"the model has nv = {tree.nv + ROOT_NV[added]} velocity coordinates "
                           f"(with its root joint); the limit is {max_nv}")
    if tree.moving_joints + (added != "fixed") == 0:
        raise InvalidModel("the description has no joint: nothing can move")
    _keyframes(sections.get("keyframe"), nq, added)
    return MJCFSummary(
        robot_name=root.get("model") or "mjcf", bodies=tree.bodies,
        moving_joints=tree.moving_joints, depth=tree.depth, root_joint=served,
        added_root_joint=added, angle_in_degrees=degrees, nq=nq, findings=tree.findings,
        notes=notes + _equality_notes(sections.get("equality")))
