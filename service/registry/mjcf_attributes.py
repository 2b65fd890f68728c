"""MJCF attributes: which ones hold numbers, how many, and how default classes combine them.

Pinocchio's MJCF parser reads numeric attributes with C++ streams and does not check that the
read succeeded: "1 2 abc", "nan", or too few numbers leave uninitialised memory in the model.
So every numeric attribute Pinocchio (or MuJoCo) defines is checked here, in every element and
in every `<default>` class: tokens must be plain decimal numbers (`[+-]digits[.digits][e±digits]`,
no `nan`, `inf`, hex or `_`), finite as float64, and as many as the attribute takes.

Default classes follow what Pinocchio does (and MuJoCo in the common cases): the top-level
`<default>` holds the main defaults; a nested `<default class="c">` inherits its parent's
`<joint>`, `<geom>` and `<site>` attributes; an element's effective attributes are the main
defaults, then its body's `childclass`, then its own `class`, then its own attributes.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from xml.etree.ElementTree import Element

import numpy as np

from service.errors import InvalidModel

_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_INTEGER = re.compile(r"[+-]?[0-9]+")
_NON_FINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)


@dataclass(frozen=True)
class Count:
    """How many numbers an attribute takes: from `low` to `high` (None: no bound), in steps."""

    low: int
    high: int | None
    step: int = 1

    def admits(self, n: int) -> bool:
        return (n >= self.low and (self.high is None or n <= self.high)
                and (n - self.low) % self.step == 0)

    def describe(self) -> str:
        if self.high == self.low:
            return f"{self.low}"
        if self.high is None:
            return f"a multiple of {self.step}" if self.step > 1 else f"at least {self.low}"
        return f"{self.low} to {self.high}"


def _n(k: int) -> Count:
    return Count(k, k)


ANY = Count(1, None)
PLACEMENT = {"pos": _n(3), "quat": _n(4), "axisangle": _n(4), "euler": _n(3),
             "xyaxes": _n(6), "zaxis": _n(3)}
ORIENTATIONS = ("quat", "axisangle", "euler", "xyaxes", "zaxis")
SOLVER = {"solref": _n(2), "solimp": Count(3, 5), "margin": _n(1), "gap": _n(1)}

# tag → numeric attribute → how many numbers.
NUMERIC: dict[str, dict[str, Count]] = {
    "compiler": {"boundmass": _n(1), "boundinertia": _n(1), "settotalmass": _n(1)},
    "option": {"gravity": _n(3), "timestep": _n(1), "wind": _n(3), "magnetic": _n(3),
               "density": _n(1), "viscosity": _n(1)},
    "body": {**PLACEMENT, "gravcomp": _n(1)},
    "inertial": {**PLACEMENT, "mass": _n(1), "diaginertia": _n(3), "fullinertia": _n(6)},
    "joint": {**PLACEMENT, "axis": _n(3), "range": _n(2), "actuatorfrcrange": _n(2),
              "springref": _n(1), "damping": _n(1), "armature": _n(1), "frictionloss": _n(1),
              "ref": _n(1), "margin": _n(1), "stiffness": _n(1), "springdamper": _n(2),
              "solreflimit": _n(2), "solimplimit": Count(3, 5), "solreffriction": _n(2),
              "solimpfriction": Count(3, 5), "user": ANY},
    "freejoint": {},
    "geom": {**PLACEMENT, **SOLVER, "size": Count(1, 3), "fromto": _n(6), "density": _n(1),
             "mass": _n(1), "rgba": _n(4), "friction": Count(1, 3), "solmix": _n(1),
             "fluidcoef": _n(5), "user": ANY},
    "site": {**PLACEMENT, "size": Count(1, 3), "fromto": _n(6), "rgba": _n(4), "user": ANY},
    "camera": {**PLACEMENT, "fovy": _n(1), "ipd": _n(1)},
    "light": {"pos": _n(3), "dir": _n(3), "attenuation": _n(3), "cutoff": _n(1),
              "exponent": _n(1), "ambient": _n(3), "diffuse": _n(3), "specular": _n(3)},
    "mesh": {"scale": _n(3), "vertex": Count(3, None, 3), "normal": Count(3, None, 3),
             "texcoord": Count(2, None, 2), "refpos": _n(3), "refquat": _n(4)},
    "material": {"rgba": _n(4), "emission": _n(1), "specular": _n(1), "shininess": _n(1),
                 "reflectance": _n(1), "texrepeat": _n(2)},
    "texture": {"rgb1": _n(3), "rgb2": _n(3), "markrgb": _n(3), "random": _n(1),
                "gridsize": _n(2)},
    "key": {"time": _n(1), "qpos": ANY, "qvel": ANY, "act": ANY, "ctrl": ANY,
            "mpos": Count(3, None, 3), "mquat": Count(4, None, 4)},
    "connect": {"anchor": _n(3), **SOLVER},
    "weld": {"anchor": _n(3), "relpose": _n(7), "torquescale": _n(1), **SOLVER},
}
INTEGER: dict[str, tuple[str, ...]] = {
    "geom": ("contype", "conaffinity", "group", "priority", "condim"),
    "site": ("group",), "joint": ("group",), "mesh": ("face",),
    "texture": ("width", "height"),
}
# Element kinds whose attributes nested default classes inherit (as Pinocchio does).
INHERITED = ("joint", "geom", "site")


def chain_body_name(body: str, index: int) -> str:
    """The name of the `index`-th (from 1) massless body split off a multi-joint body."""
    return f"{body}#{index}"


def shown(name: str) -> str:
    """A name from the description as it may appear in a message: printable, at most 64 chars."""
    clean = "".join(c if c.isprintable() else "?" for c in name)
    return clean if len(clean) <= 64 else clean[:64] + "…"


def numbers(value: str, what: str, count: Count | None = None) -> list[float]:
    """The numbers of an attribute value; `InvalidModel` naming `what` unless all are finite
    decimal numbers and (with `count`) as many as expected."""
    tokens = value.split()
    if count is not None and not count.admits(len(tokens)):
        raise InvalidModel(f"{what} must have {count.describe()} numbers, found {len(tokens)}")
    out = []
    for token in tokens:
        if _NON_FINITE.fullmatch(token):
            raise InvalidModel(f"{what} must be finite")
        if not _NUMBER.fullmatch(token):
            raise InvalidModel(f"{what} is not a number (plain decimal numbers only)")
        x = float(token)
        if not math.isfinite(x):
            raise InvalidModel(f"{what} must be finite (a number beyond float64 range)")
        out.append(x)
    return out


def check_numbers(el: Element, label: str) -> None:
    """Check every numeric and integer attribute of one element (labelled `label` in errors)."""
    for attr, count in NUMERIC.get(el.tag, {}).items():
        value = el.get(attr)
        if value is not None:
            numbers(value, f"{label}: {attr}", count)
    for attr in INTEGER.get(el.tag, ()):
        value = el.get(attr)
        if value is not None and not all(_INTEGER.fullmatch(t) for t in value.split()):
            raise InvalidModel(f"{label}: {attr} must be integers")


@dataclass
class DefaultClasses:
    """Default attributes: the main defaults and each named class, flattened by inheritance."""

    main: dict[str, dict[str, str]] = field(default_factory=dict)
    named: dict[str, dict[str, dict[str, str]]] = field(default_factory=dict)

    def effective(self, el: Element, childclass: str | None, label: str) -> dict[str, str]:
        """The attributes of `el` after applying main defaults, `childclass` and its class."""
        out = dict(self.main.get(el.tag, {}))
        for cls in (childclass, el.get("class")):
            if cls is not None:
                out.update(self.named_class(cls, label).get(el.tag, {}))
        out.update(el.attrib)
        return out

    def named_class(self, cls: str, label: str) -> dict[str, dict[str, str]]:
        if cls not in self.named:
            raise InvalidModel(f"{label}: default class '{shown(cls)}' is not defined")
        return self.named[cls]


def _own(el: Element) -> dict[str, dict[str, str]]:
    # Pinocchio reads the first child of each kind in a default class.
    out: dict[str, dict[str, str]] = {}
    for child in el:
        if child.tag != "default" and child.tag not in out:
            out[child.tag] = dict(child.attrib)
    return out


def default_classes(top: Element | None) -> DefaultClasses:
    """Flatten the `<default>` tree (iteratively: its depth comes from the upload)."""
    classes = DefaultClasses()
    if top is None:
        return classes
    classes.main = _own(top)
    stack: list[tuple[Element, dict[str, dict[str, str]], bool]] = [(top, {}, True)]
    while stack:
        el, parent, is_top = stack.pop()
        own = _own(el)
        flat = dict(own)
        for tag in INHERITED:
            if tag in parent:
                flat[tag] = {**parent[tag], **own.get(tag, {})}
        cls = el.get("class")
        if set(el.attrib) - {"class"}:
            raise InvalidModel(f"a <default>{f' class {shown(cls)!r}' if cls else ''} has "
                               "attributes other than class")
        if cls is None and not is_top:
            raise InvalidModel("a nested <default> has no class attribute")
        if cls is not None:
            if cls in classes.named:
                raise InvalidModel(f"default class '{shown(cls)}' is defined twice")
            classes.named[cls] = flat
        stack.extend((child, flat, False) for child in el if child.tag == "default")
    return classes


def rotation_given(attrs: dict[str, str], label: str) -> bool:
    """Check the orientation attributes of one element; True if it has a non-identity one."""
    given = [a for a in ORIENTATIONS if a in attrs]
    if len(given) > 1:
        raise InvalidModel(f"{label}: give one orientation, not {' and '.join(given)}")
    if not given:
        return False
    kind = given[0]
    v = np.array(numbers(attrs[kind], f"{label}: {kind}"))
    if kind == "quat":
        if np.linalg.norm(v) < 1e-9:
            raise InvalidModel(f"{label}: quat is zero")
        return not np.allclose(np.abs(v / np.linalg.norm(v)), [1, 0, 0, 0])
    if kind == "axisangle":
        if abs(np.linalg.norm(v[:3]) - 1.0) > 1e-6:
            raise InvalidModel(f"{label}: the axisangle axis must have unit length "
                               "(Pinocchio does not normalize it)")
        return bool(v[3] != 0.0)
    if kind == "xyaxes":
        x, y = v[:3], v[3:]
        if np.linalg.norm(x) < 1e-9 or np.linalg.norm(np.cross(x, y)) < 1e-9:
            raise InvalidModel(f"{label}: xyaxes needs a non-zero x and a y not parallel to it")
        return True
    if kind == "zaxis":
        if np.linalg.norm(v) < 1e-9:
            raise InvalidModel(f"{label}: zaxis is zero")
        return not np.allclose(v / np.linalg.norm(v), [0, 0, 1])
    return bool(np.any(v != 0.0))  # euler
