"""The body tree of an MJCF `<worldbody>`: joints, geoms and inertials, checked body by body.

Names follow Pinocchio's MJCF parser: an unnamed body is called after its parent + "Bis", an
unnamed joint `<body>Joint_<k>`, an unnamed free joint `<body>_free`; a body with several joints
is served as a chain of one-joint bodies `<body>#1`, ... (see `mjcf_split`). The walk is
iterative (depth comes from the upload) and bounded by the shared caps (`Limits`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from xml.etree.ElementTree import Element

import numpy as np

from service.errors import InvalidModel
from service.registry.mjcf_attributes import (
    DefaultClasses,
    chain_body_name,
    numbers,
    rotation_given,
    shown,
)
from service.registry.urdf_check import (
    ABS_TOL,
    NEGATIVE_REL_TOL,
    TRIANGLE_REL_TOL,
    Finding,
    Limits,
)

BODY_CHILDREN = ("inertial", "joint", "freejoint", "geom", "site", "camera", "light", "body")
JOINT_NQ = {"hinge": 1, "slide": 1, "ball": 4, "free": 7}
JOINT_NV = {"hinge": 1, "slide": 1, "ball": 3, "free": 6}
GEOM_SIZES = {"sphere": 1, "capsule": 2, "cylinder": 2, "box": 3, "ellipsoid": 3, "plane": 3,
              "mesh": 0}
RESERVED = ("universe", "root_joint")


@dataclass
class BodyTree:
    """What the walk learned about the tree under the top body."""

    top_body: str
    top_joints: list[tuple[str, str]]  # (name, type) of the top body's joints
    top_rotated: bool
    top_translated: bool
    split_bodies: int = 0  # bodies with several joints, served as chains
    bodies: int = 0
    moving_joints: int = 0
    depth: int = 0
    nq: int = 0
    nv: int = 0
    findings: list[Finding] = field(default_factory=list)


def inertia_findings(body: str, tensor: np.ndarray) -> list[Finding]:
    moments = np.linalg.eigvalsh(tensor)
    shown_moments = ", ".join(f"{m:.6g}" for m in moments)
    out = []
    largest = float(np.max(np.abs(moments)))
    if moments[0] < -(NEGATIVE_REL_TOL * largest + ABS_TOL):
        out.append(Finding("negative_principal_moment", "body", body,
                           f"body '{body}': inertia has a negative principal moment "
                           f"{moments[0]:.6g} kg·m² (principal moments {shown_moments})"))
    a, b, c = moments
    if a + b < c - (TRIANGLE_REL_TOL * abs(float(np.sum(moments))) + ABS_TOL):
        out.append(Finding("triangle_inequality", "body", body,
                           f"body '{body}': principal moments {shown_moments} kg·m² violate the "
                           f"triangle inequality ({a:.6g} + {b:.6g} < {c:.6g})"))
    return out


def _joint(el: Element, attrs: dict[str, str], body: str, index: int, label: str
           ) -> tuple[str, str]:
    """Check one joint; (its name as Pinocchio names it, its type)."""
    if el.tag == "freejoint":
        return el.get("name") or f"{body}_free", "free"
    name = el.get("name") or f"{body}Joint_{index}"
    label = f"joint '{shown(name)}'" if el.get("name") else f"joint {index} of {label}"
    kind = attrs.get("type", "hinge")
    if kind not in JOINT_NQ:
        raise InvalidModel(f"{label}: type '{shown(kind)}' is not one of "
                           f"{', '.join(JOINT_NQ)}")
    rotation_given(attrs, label)
    if kind in ("hinge", "slide"):
        axis = numbers(attrs.get("axis", "0 0 1"), f"{label}: axis")
        if float(np.linalg.norm(axis)) < 1e-9:
            raise InvalidModel(f"{label}: axis is zero; a {kind} joint needs a direction")
        if "range" in attrs:
            low, high = numbers(attrs["range"], f"{label}: range")
            if low > high:
                raise InvalidModel(f"{label}: range lower bound exceeds its upper bound")
        if "ref" in attrs and numbers(attrs["ref"], f"{label}: ref")[0] != 0.0:
            raise InvalidModel(f"{label}: a non-zero ref is not supported (Pinocchio's q would "
                               "be MuJoCo's qpos minus ref); move the offset into the body pose")
    for attr in ("armature", "margin", "damping"):
        if attr in attrs and numbers(attrs[attr], f"{label}: {attr}")[0] < 0:
            raise InvalidModel(f"{label}: {attr} must not be negative")
    return name, kind


def _geom(attrs: dict[str, str], label: str) -> tuple[str, bool]:
    """Check one geom; (its type, whether it counts for the body's inertia)."""
    kind = attrs.get("type", "sphere")
    if kind not in GEOM_SIZES:
        raise InvalidModel(f"{label}: geom type '{shown(kind)}' is not supported by Pinocchio's "
                           f"MJCF parser (supported: {', '.join(GEOM_SIZES)})")
    if "shellinertia" in attrs:
        raise InvalidModel(f"{label}: shellinertia is not supported by Pinocchio's MJCF parser")
    rotation_given(attrs, label)
    if kind == "mesh" and not attrs.get("mesh"):
        raise InvalidModel(f"{label}: a mesh geom needs a mesh attribute")
    fromto = "fromto" in attrs
    if fromto:
        if kind in ("sphere", "plane", "mesh"):
            raise InvalidModel(f"{label}: fromto works with capsules, cylinders, boxes and "
                               "ellipsoids only")
        ends = np.array(numbers(attrs["fromto"], f"{label}: fromto"))
        if float(np.linalg.norm(ends[3:] - ends[:3])) < 1e-12:
            raise InvalidModel(f"{label}: fromto has zero length")
    need = 1 if fromto and kind != "mesh" else GEOM_SIZES[kind]
    if need:
        if "size" not in attrs:
            raise InvalidModel(f"{label}: a {kind} geom needs a size")
        size = numbers(attrs["size"], f"{label}: size")
        if len(size) < need:
            raise InvalidModel(f"{label}: a {kind} geom needs {need} size numbers, "
                               f"found {len(size)}")
        if kind != "plane" and min(size[:need]) <= 0:
            raise InvalidModel(f"{label}: size must be positive")
    for attr in ("density", "mass"):
        if attr in attrs and numbers(attrs[attr], f"{label}: {attr}")[0] < 0:
            raise InvalidModel(f"{label}: {attr} must not be negative")
    visual = (attrs.get("contype", "1").strip() == "0"
              and attrs.get("conaffinity", "1").strip() == "0")
    return kind, not visual


def _inertial(el: Element, body: str, findings: list[Finding]) -> None:
    label = f"the <inertial> of body '{body}'"
    if "mass" not in el.attrib:
        raise InvalidModel(f"{label} needs a mass")
    if numbers(el.attrib["mass"], f"{label}: mass")[0] < 0:
        raise InvalidModel(f"body '{body}': mass is negative")
    rotation_given(dict(el.attrib), label)
    if "diaginertia" in el.attrib:
        tensor = np.diag(numbers(el.attrib["diaginertia"], f"{label}: diaginertia"))
    elif "fullinertia" in el.attrib:
        xx, yy, zz, xy, xz, yz = numbers(el.attrib["fullinertia"], f"{label}: fullinertia")
        tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    else:
        raise InvalidModel(f"{label} needs diaginertia or fullinertia")
    findings.extend(inertia_findings(body, tensor))


def walk_bodies(top: Element, classes: DefaultClasses, limits: Limits,
                inertia_from_geom: str) -> BodyTree:
    """Check every body under (and including) the top body."""
    tree: BodyTree | None = None
    body_names: set[str] = set()
    joint_names: set[str] = set()
    stack: list[tuple[Element, int, str | None, str]] = [(top, 1, None, "")]
    while stack:
        el, depth, childclass, parent = stack.pop()
        name = el.get("name") or parent + "Bis"
        label = f"body '{shown(name)}'"
        if depth > limits.max_depth:
            raise InvalidModel(f"{label}: the body tree is deeper than {limits.max_depth}")
        if name in body_names or name in RESERVED:
            raise InvalidModel(f"{label}: the name is used twice or reserved (unnamed bodies are "
                               "named after their parent + 'Bis'); give bodies unique names")
        body_names.add(name)
        childclass = el.get("childclass") or childclass
        if childclass is not None:
            classes.named_class(childclass, label)
        translated = any(x != 0.0 for x in numbers(el.get("pos", "0 0 0"), f"{label}: pos"))
        rotated = rotation_given(dict(el.attrib), label)
        joints: list[tuple[str, str]] = []
        masses_from_geoms: list[str] = []
        inertials = [c for c in el if c.tag == "inertial"]
        for child in el:
            if child.tag not in BODY_CHILDREN:
                raise InvalidModel(f"{label}: <{shown(str(child.tag))}> is not supported inside a "
                                   f"body (supported: {', '.join(BODY_CHILDREN)})")
            if child.tag in ("joint", "freejoint"):
                attrs = classes.effective(child, childclass, label)
                joints.append(_joint(child, attrs, name, len(joints), label))
            elif child.tag in ("geom", "site"):
                attrs = classes.effective(child, childclass, label)
                what = f"a <{child.tag}> of {label}"
                if child.tag == "site":
                    rotation_given(attrs, what)
                else:
                    kind, counts = _geom(attrs, what)
                    if counts:
                        masses_from_geoms.append(kind)
        if len(inertials) > 1:
            raise InvalidModel(f"{label} has more than one <inertial>")
        from_geoms = inertia_from_geom == "true" or (inertia_from_geom == "auto"
                                                     and not inertials)
        if inertia_from_geom == "false" and not inertials:
            raise InvalidModel(f"{label} has no <inertial> and inertiafromgeom is false")
        if from_geoms and "mesh" in masses_from_geoms:
            raise InvalidModel(f"{label}: its inertia would come from its geoms, and one is a "
                               "mesh, which robodyn does not read; give the body an <inertial>")
        if tree is None:
            tree = BodyTree(top_body=name, top_joints=joints, top_rotated=rotated,
                            top_translated=translated)
        if not from_geoms:
            _inertial(inertials[0], name, tree.findings)
        kinds = [k for _, k in joints]
        if depth > 1 and "free" in kinds:
            raise InvalidModel(f"{label}: only the top body may have a free joint")
        if len(joints) > 1 and "free" in kinds:
            raise InvalidModel(f"{label}: a free joint must be its body's only joint")
        for joint_name, _ in joints:
            if joint_name in joint_names or joint_name in RESERVED:
                raise InvalidModel(f"joint '{shown(joint_name)}': the name is used twice or "
                                   "reserved; give joints unique names")
            joint_names.add(joint_name)
        for index in range(1, len(joints)):  # the chain's extra bodies
            extra = chain_body_name(name, index)
            if extra in body_names:
                raise InvalidModel(f"{label}: its joints are served as a chain with a body "
                                   f"'{shown(extra)}', a name already used; rename that body")
            body_names.add(extra)
        tree.split_bodies += len(joints) > 1
        tree.bodies += max(1, len(joints))
        tree.moving_joints += len(joints)
        tree.depth = max(tree.depth, depth)
        tree.nq += sum(JOINT_NQ[k] for k in kinds)
        tree.nv += sum(JOINT_NV[k] for k in kinds)
        if tree.bodies > limits.max_links:
            raise InvalidModel(f"the description has more than {limits.max_links} bodies")
        max_joints = getattr(limits, "max_moving_joints", None)  # caps differ between versions
        if max_joints is not None and tree.moving_joints > max_joints:
            raise InvalidModel(f"the description has more than {max_joints} joints")
        max_nv = getattr(limits, "max_nv", None)
        if max_nv is not None and tree.nv > max_nv:
            raise InvalidModel(f"the description has more than {max_nv} velocity coordinates")
        stack.extend((child, depth + 1, childclass, name)
                     for child in reversed(el) if child.tag == "body")
    assert tree is not None
    return tree
