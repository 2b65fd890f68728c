"""What a robot looks like: the visual elements of its description, and the mesh files they name.

A visual entry (the shape of `GET /v1/robots/{id}/visuals`) is

    {"name": "<link>_<index>", "frame": the link's body frame (Pinocchio: the URDF link name),
     "placement": {"translation": [x, y, z] in m, "rotation": 3×3 row-major},  # in that frame
     "geometry": {"type": "mesh", "asset": key, "scale": [3]}
               | {"type": "box", "size": [3]} | {"type": "sphere", "radius": r}
               | {"type": "cylinder" | "capsule", "radius": r, "length": l},   # m, along z
     "color": [r, g, b, a] in 0–1, or None}

An asset key is the mesh reference as a normalized relative path: `package://pkg/x.stl` is
`pkg/x.stl`.
`urdf_visuals` reads URDF `<visual>` elements in pure Python (defusedxml, bounded), so an
untrusted upload never reaches a native parser here. Catalog robots get their visuals and the
files they reference (`asset_paths`, inside example-robot-data only) when they load; uploads get
theirs lazily on the first request (`ensure_visuals`, run off the event loop).
"""

from __future__ import annotations

import logging
import math
import posixpath
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any
from xml.etree.ElementTree import Element

from service.errors import InvalidModel
from service.registry.robot import Robot
from service.registry.safe_xml import parse_bounded, read_numbers

log = logging.getLogger("robodyn.visuals")

MAX_ELEMENTS = 2_000_000  # catalog and stored descriptions were already checked; a cap anyway
MAX_DEPTH = 64
IDENTITY = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]


def asset_key(filename: str) -> str | None:
    """The asset key of a mesh reference: `package://pkg/x` → `pkg/x`, a relative path
    normalized (no `./`); None for an absolute path, a URL or a path that leaves its root."""
    name = filename.strip()
    if name.startswith("package://"):
        name = name[len("package://") :].lstrip("/")  # (some write package:///pkg/x)
    elif "://" in name or name.startswith("/") or "\\" in name:
        return None
    key = posixpath.normpath(name)
    if key in ("", ".") or key.startswith("/") or ".." in key.split("/"):
        return None
    return key


def rpy_matrix(roll: float, pitch: float, yaw: float) -> list[list[float]]:
    """R = Rz(yaw) Ry(pitch) Rx(roll), the URDF convention, as a row-major 3×3 list."""
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    rows = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    return [[x + 0.0 for x in row] for row in rows]  # no -0.0


def _color(material: Element | None, named: Mapping[str, list[float]]) -> list[float] | None:
    if material is None:
        return None
    color = material.find("color")
    if color is not None and color.get("rgba") is not None:
        rgba = read_numbers(color.get("rgba"), 4, "material color rgba")
        return [min(1.0, max(0.0, x)) for x in rgba]
    return named.get(material.get("name", ""))


def shape_geometry(geometry: Element) -> dict[str, Any] | None:
    """The first usable shape of a `<geometry>` element (entries as in the module docstring),
    None if it has none."""
    for shape in geometry:
        tag = shape.tag
        if tag == "mesh":
            key = asset_key(shape.get("filename", ""))
            if key is None:
                return None
            scale = read_numbers(shape.get("scale"), 3, "mesh scale", "1 1 1")
            return {"type": "mesh", "asset": key, "scale": scale}
        if tag == "box":
            return {"type": "box", "size": read_numbers(shape.get("size"), 3, "box size")}
        if tag == "sphere":
            return {
                "type": "sphere",
                "radius": read_numbers(shape.get("radius"), 1, "sphere radius")[0],
            }
        if tag in ("cylinder", "capsule"):
            return {
                "type": tag,
                "radius": read_numbers(shape.get("radius"), 1, f"{tag} radius")[0],
                "length": read_numbers(shape.get("length"), 1, f"{tag} length")[0],
            }
    return None


def _visual(
    link: str, index: int, visual: Element, named: Mapping[str, list[float]]
) -> dict[str, Any] | None:
    geometry_element = visual.find("geometry")
    if geometry_element is None:
        return None
    geometry = shape_geometry(geometry_element)
    if geometry is None:
        return None
    origin = visual.find("origin")
    xyz = read_numbers(None if origin is None else origin.get("xyz"), 3, "origin xyz", "0 0 0")
    rpy = read_numbers(None if origin is None else origin.get("rpy"), 3, "origin rpy", "0 0 0")
    # named as Pinocchio names its geometries: unique, where descriptions reuse visual names
    return {
        "name": f"{link}_{index}",
        "frame": link,
        "placement": {"translation": xyz, "rotation": rpy_matrix(*rpy)},
        "geometry": geometry,
        "color": _color(visual.find("material"), named),
    }


def urdf_visuals(urdf_text: str) -> list[dict[str, Any]]:
    """Every usable `<visual>` of every link of a URDF, in document order (entries as in the
    module docstring). A visual whose geometry or numbers cannot be read is left out (the
    model itself was validated when it was stored; the picture is best effort)."""
    root = parse_bounded(urdf_text, MAX_ELEMENTS, MAX_DEPTH)
    named: dict[str, list[float]] = {}
    for material in root.findall("material"):
        try:
            color = _color(material, {})
        except InvalidModel:
            continue
        if color is not None and material.get("name"):
            named[material.get("name", "")] = color
    visuals = []
    for link in root.iter("link"):
        name = link.get("name")
        if not name:
            continue
        for index, visual in enumerate(link.findall("visual")):
            try:
                entry = _visual(name, index, visual, named)
            except InvalidModel:
                entry = None
            if entry is not None:
                visuals.append(entry)
    return visuals


def on_model(
    visuals: list[dict[str, Any]], has_body_frame: Callable[[str], bool]
) -> list[dict[str, Any]]:
    """The visuals whose link is a body frame of the model (a reduced catalog model, e.g.
    talos_legs, has fewer links than its description)."""
    return [v for v in visuals if has_body_frame(v["frame"])]


def resolve_assets(
    visuals: list[dict[str, Any]], package_root: Path, description_dir: Path
) -> tuple[list[dict[str, Any]], dict[str, Path]]:
    """For a description installed on disk (the catalog): the visuals whose mesh files exist,
    and `asset_paths` mapping each referenced key to its file. `pkg/x` is looked up as
    `package_root/pkg/x` and a relative path next to the description; a file outside
    `package_root` (a symlink out, say) is never served. Keys stay the description's own
    references, rebased under `package_root` for relative ones."""
    root = package_root.resolve()
    kept: list[dict[str, Any]] = []
    paths: dict[str, Path] = {}
    for visual in visuals:
        geometry = visual["geometry"]
        if geometry["type"] != "mesh":
            kept.append(visual)
            continue
        key = geometry["asset"]
        candidates = [root / key, description_dir / key]
        found = next(
            (
                p.resolve()
                for p in candidates
                if p.resolve().is_file() and p.resolve().is_relative_to(root)
            ),
            None,
        )
        if found is None:
            log.info("visual %r: mesh %r not found; left out", visual["name"], key)
            continue
        served = found.relative_to(root).as_posix()
        if served != key:
            visual = {**visual, "geometry": {**geometry, "asset": served}}
        paths[served] = found
        kept.append(visual)
    return kept, paths


def ensure_visuals(
    robot: Robot,
    base: Callable[[str], Robot],
    description: Callable[[str], Mapping[str, Any] | None],
) -> None:
    """Fill `robot.visuals` (and `asset_paths` of a reduced model) if not computed yet. Blocking
    (parses XML): call it off the event loop. `base(id)` gives a served robot, `description(id)`
    an upload's stored record (with "format" and "description")."""
    if robot.visuals is not None:
        return
    has_body = _body_frames(robot)
    if robot.origin is not None:  # a reduced model keeps its base's links as body frames
        parent = base(str(robot.origin["robot"]))
        ensure_visuals(parent, base, description)
        visuals = on_model(parent.visuals or [], has_body)
        keys = {v["geometry"]["asset"] for v in visuals if v["geometry"]["type"] == "mesh"}
        robot.asset_paths = {k: p for k, p in parent.asset_paths.items() if k in keys}
        robot.visuals = visuals
        return
    record = description(robot.id) if robot.source == "upload" else None
    urdf = (
        None
        if record is None
        else (
            record["description"]
            if record.get("format", "urdf") == "urdf"
            else record.get("expanded_urdf")
        )
    )  # a xacro upload: the URDF it expanded to
    visuals = [] if urdf is None else on_model(urdf_visuals(urdf), has_body)
    # Only the meshes the visuals name are served (not collision meshes, not included files).
    keys = {v["geometry"]["asset"] for v in visuals if v["geometry"]["type"] == "mesh"}
    robot.asset_paths = {k: p for k, p in robot.asset_paths.items() if k in keys}
    robot.visuals = visuals


def _body_frames(robot: Robot) -> Callable[[str], bool]:
    names = {f.name for f in robot.model.frames if str(f.type).endswith("BODY")}
    return names.__contains__
