"""MJCF compiled by MuJoCo itself (`mujoco.MjModel.from_xml_string(text, assets)`).

Before the native compiler sees anything, `preflight` parses the description and every XML asset
with a safe XML parser (no DTD, no entities, no external references), bounds its size, and
refuses file references that could reach outside the upload: any `file` attribute, `meshdir`,
`texturedir` or `assetdir` that is absolute or climbs with `..`. The compiler then finds every
file in the assets given in memory (MuJoCo's virtual file system); in the builder process it runs
in an empty private directory, so a relative reference that is not an asset finds nothing.
MuJoCo's own error message (which names the element and line) becomes the 422 detail.
"""

from __future__ import annotations

import logging
import os
import re
import tempfile
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import PurePosixPath
from typing import Any
from xml.etree.ElementTree import Element

import defusedxml.ElementTree as SafeET
import mujoco
import numpy as np
from defusedxml import DefusedXmlException

from service.errors import InvalidModel
from service.registry.urdf_check import Limits

log = logging.getLogger("robodyn.mjcf")
PATH_ATTRIBUTES = ("file", "meshdir", "texturedir", "assetdir")
MAX_MESSAGE = 600
_TMP = re.compile(r"/\S*robodyn-mjcf-[^/\s]*/?")


def shown(text: str, limit: int = 80) -> str:
    """A user-given string as quoted in a message: printable, at most `limit` characters."""
    text = "".join(c if c.isprintable() else "?" for c in text)
    return text if len(text) <= limit else text[:limit] + "…"


def parse_xml(text: str | bytes, what: str, limits: Limits) -> Element:
    """Parse XML safely (no DTD, entities or external references), within the element and
    nesting caps; `what` names the file in messages."""
    try:
        root: Element = SafeET.fromstring(
            text, forbid_dtd=True, forbid_entities=True, forbid_external=True
        )
    except DefusedXmlException:
        raise InvalidModel(
            f"{what}: the XML has a DTD, entity or external reference; these are refused"
        ) from None
    except (SafeET.ParseError, ValueError) as exc:
        raise InvalidModel(f"{what} is not well-formed XML ({shown(str(exc), 200)})") from None
    count = sum(1 for _ in root.iter())
    if count > limits.max_elements:
        raise InvalidModel(f"{what} has {count} XML elements; the limit is {limits.max_elements}")
    stack = [(root, 1)]
    while stack:
        el, depth = stack.pop()
        if depth > limits.max_depth + 8:
            raise InvalidModel(
                f"{what}: <{shown(str(el.tag))}> is nested deeper than "
                f"{limits.max_depth + 8} XML levels"
            )
        for attr in ("name", "model"):  # names are echoed in every answer: bounded
            value = el.get(attr)
            if value is not None and len(value) > limits.max_name_length:
                raise InvalidModel(
                    f"{what}: <{shown(str(el.tag))}> {attr}='{shown(value)}' is "
                    f"{len(value)} characters long; the limit is "
                    f"{limits.max_name_length} (ROBODYN_MAX_NAME_LENGTH)"
                )
        stack.extend((child, depth + 1) for child in el)
    return root


def _check_paths(root: Element, what: str) -> None:
    for el in root.iter():
        for attr in PATH_ATTRIBUTES:
            value = el.get(attr)
            if value is None:
                continue
            path = PurePosixPath(value.replace("\\", "/"))
            if path.is_absolute() or ".." in path.parts or ":" in value or value.startswith("~"):
                raise InvalidModel(
                    f"{what}: <{shown(str(el.tag))}> {attr}='{shown(value)}' "
                    "points outside the upload; references must be relative "
                    "paths to the upload's assets"
                )


def preflight(text: str, assets: Mapping[str, bytes], limits: Limits) -> str:
    """Check the description and its XML assets (see the module docstring); the model's name."""
    root = parse_xml(text, "the MJCF", limits)
    if root.tag != "mujoco":
        raise InvalidModel(f"the root element is <{shown(str(root.tag))}>; an MJCF needs <mujoco>")
    _check_paths(root, "the MJCF")
    for key, data in assets.items():
        if key.lower().endswith(".xml"):
            _check_paths(parse_xml(data, f"asset '{shown(key)}'", limits), f"asset '{key}'")
    return root.get("model") or "mjcf"


@contextmanager
def empty_working_directory() -> Iterator[None]:
    """Run in a new empty private directory (the builder process, before its limits forbid
    file writes), removed on exit."""
    old = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="robodyn-mjcf-") as tmp:
        os.chdir(tmp)
        try:
            yield
        finally:
            os.chdir(old)


def _warning(message: str) -> None:
    log.info("MuJoCo: %s", message)


# MuJoCo's default warning handler appends to MUJOCO_LOG.TXT in the working directory (the
# builder process may not write files): its warnings go to the log instead.
mujoco.set_mju_user_warning(_warning)


def compile_mjcf(text: str, assets: Mapping[str, bytes]) -> Any:
    """MuJoCo's compiled model (`mujoco.MjModel`) of MJCF `text` with `assets` (key → bytes).

    The builder process compiles in `empty_working_directory`. The serving process compiles
    only descriptions that compiled there before (stored uploads), so with every file found
    among their assets.
    """
    try:
        mj = mujoco.MjModel.from_xml_string(text, dict(assets))
    except ValueError as exc:
        message = _TMP.sub("", str(exc)).strip()
        if len(message) > MAX_MESSAGE:
            message = message[:MAX_MESSAGE] + "…"
        raise InvalidModel(f"MuJoCo could not compile the MJCF: {message}") from None
    check_finite(mj)
    return mj


_OPTION_FIELDS = (
    "gravity",
    "wind",
    "magnetic",
    "timestep",
    "density",
    "viscosity",
    "impratio",
    "tolerance",
    "o_margin",
    "o_solref",
    "o_solimp",
    "o_friction",
)
_ELEMENTS = {  # model array prefix → (MuJoCo object type, MJCF element)
    "body": (mujoco.mjtObj.mjOBJ_BODY, "body"),
    "jnt": (mujoco.mjtObj.mjOBJ_JOINT, "joint"),
    "geom": (mujoco.mjtObj.mjOBJ_GEOM, "geom"),
    "site": (mujoco.mjtObj.mjOBJ_SITE, "site"),
    "key": (mujoco.mjtObj.mjOBJ_KEY, "key"),
    "actuator": (mujoco.mjtObj.mjOBJ_ACTUATOR, "actuator"),
    "tendon": (mujoco.mjtObj.mjOBJ_TENDON, "tendon"),
    "cam": (mujoco.mjtObj.mjOBJ_CAMERA, "camera"),
}


_GIVEN = frozenset(
    (
        "pos",
        "quat",
        "mass",
        "inertia",
        "ipos",
        "iquat",
        "axis",
        "range",
        "size",
        "qpos",
        "qvel",
        "act",
        "ctrl",
        "mpos",
        "mquat",
        "time",
        "friction",
        "armature",
        "damping",
        "stiffness",
        "springref",
        "frictionloss",
        "gear",
        "margin",
        "ref",
    )
)


def check_finite(mj: Any) -> None:
    """Refuse a compiled model holding a NaN or an infinity (MuJoCo's compiler accepts `nan` in
    any number, only warning): `<option gravity="nan 0 0">`, a keyframe's `qpos`, a body's
    `pos`, ... The detail names the element (and its name or index) and the attribute."""
    for name in _OPTION_FIELDS:
        value = np.asarray(getattr(mj.opt, name, 0.0), dtype=float)
        if not np.all(np.isfinite(value)):
            shown_name = name.removeprefix("o_")
            raise InvalidModel(
                f"<option {shown_name}> holds a non-finite number "
                f"({_numbers(value)}); every number must be finite"
            )
    # attributes the MJCF gives first, so a NaN is named where it was written (a NaN position
    # also spoils values derived from it, e.g. body_invweight0)
    names = [n for n in dir(mj) if not n.startswith("_")]
    names.sort(key=lambda n: n.partition("_")[2] not in _GIVEN)
    for field_name in names:
        try:
            value = getattr(mj, field_name)
        except Exception:  # a property the binding cannot give for this model
            continue
        if not (isinstance(value, np.ndarray) and value.dtype.kind == "f" and value.size):
            continue
        finite = np.isfinite(value)
        if finite.all():
            continue
        prefix, _, attribute = field_name.partition("_")
        row = int(np.argwhere(~finite)[0][0]) if value.ndim else 0
        if prefix in _ELEMENTS:
            obj, tag = _ELEMENTS[prefix]
            element_name = mujoco.mj_id2name(mj, obj, row)
            which = f" name='{shown(element_name)}'" if element_name else f" (number {row})"
            values = value[row] if value.ndim > 1 else value[row : row + 1]
            raise InvalidModel(
                f"<{tag}{which}> {attribute} holds a non-finite number "
                f"({_numbers(values)}); every number must be finite"
            )
        raise InvalidModel(
            f"the compiled model's {field_name} holds a non-finite number; every "
            "number of the MJCF must be finite"
        )


def _numbers(values: Any) -> str:
    flat = np.asarray(values, dtype=float).ravel()
    text = " ".join(f"{x:g}" for x in flat[:8])
    return text + (" …" if flat.size > 8 else "")
