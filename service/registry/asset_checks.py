"""What the builder process checks in an upload's assets, and what it reports about them.

Runs only in the builder process (`service.registry.build_process`), never in the serving one:

- `check_asset_texts`: every text asset is UTF-8; a `.gltf` is JSON (nesting deeper than
  Python's parser allows is refused, not a crash); an XML asset is well-formed with no DTD,
  entity or external reference, read as a stream (`expat` with a target that only counts, so no
  tree is built whatever the size) within `Limits.max_elements` elements and nesting
  `Limits.max_depth + 8` for the description types (`.xml`, `.urdf`, `.xacro`, `.srdf`,
  `.mjcf`: they are parsed into trees later); COLLADA meshes (`.dae`) are only checked to be
  well-formed. Every refusal is an `InvalidModel` naming the asset.
- `unreferenced`: the assets no text names. The texts are cut once into path-like tokens and the
  last segment of each (`package://pkg/meshes/x.stl` → `x.stl`) goes into a set; an asset is
  named when its file name is in that set. Time and memory are linear in the texts' size plus
  the number of keys (the former scan searched every tail of every key in every text).
- `missing_meshes`: the mesh files a URDF's visuals reference that are not among the assets
  (one entry per file, with the links that use it), and `outside_meshes` those referenced by a
  path no upload can hold (absolute, a `file://` URL, climbing out with `..`).
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Mapping
from typing import Any

from defusedxml import DefusedXmlException
from defusedxml.ElementTree import DefusedXMLParser, ParseError

from service.errors import InvalidModel
from service.registry.assets import MESH_TYPES, extension
from service.registry.safe_xml import XmlOverCaps, parse_bounded, shown
from service.registry.urdf_check import Limits
from service.registry.visuals import MAX_DEPTH, MAX_ELEMENTS, asset_key, urdf_visuals

XML_TYPES = ("dae", "xml", "urdf", "xacro", "srdf", "mjcf")
DESCRIPTION_XML_TYPES = ("xml", "urdf", "xacro", "srdf", "mjcf")
BINARY_TYPES = ("stl", "glb", "ply", "png", "msh", "skn")
_CHUNK = 1 << 16
_TOKEN = re.compile(r"[^\s\"'<>=(){}\[\],;]+")


class _Counter:
    """An expat target that counts elements and nesting without keeping anything."""

    def __init__(self, max_elements: int | None, max_depth: int | None) -> None:
        self.max_elements, self.max_depth = max_elements, max_depth
        self.count = self.depth = 0

    def start(self, tag: str, attrs: Mapping[str, str]) -> None:
        self.count += 1
        self.depth += 1
        if self.max_elements is not None and self.count > self.max_elements:
            raise XmlOverCaps(
                f"it has more than {self.max_elements} XML elements (limit "
                "ROBODYN_MAX_XML_ELEMENTS)"
            )
        if self.max_depth is not None and self.depth > self.max_depth:
            raise XmlOverCaps(f"it is nested deeper than {self.max_depth} XML levels")

    def end(self, tag: str) -> None:
        self.depth -= 1

    def data(self, text: str) -> None:
        pass

    def close(self) -> None:
        return None


def _xml_problem(text: str, max_elements: int | None, max_depth: int | None) -> str | None:
    """Why `text` is not an acceptable XML document, or None (streamed, no tree built)."""
    parser = DefusedXMLParser(
        target=_Counter(max_elements, max_depth),
        forbid_dtd=True,
        forbid_entities=True,
        forbid_external=True,
    )
    try:
        for start in range(0, len(text), _CHUNK):
            parser.feed(text[start : start + _CHUNK])
        parser.close()
    except XmlOverCaps as exc:
        return str(exc)
    except DefusedXmlException:
        return "XML with a DTD, entity or external reference"
    except (ParseError, ValueError, UnicodeError):
        return "not well-formed XML"
    return None


def _json_problem(text: str) -> str | None:
    try:
        json.loads(text)
    except RecursionError:
        return "JSON nested deeper than the parser allows"
    except ValueError:
        return "not JSON"
    return None


def check_asset_texts(assets: Mapping[str, bytes], limits: Limits) -> None:
    """Refuse a text asset that is not readable as its extension says (see the module
    docstring); binary types were checked by their headers in the serving process."""
    for key, data in assets.items():
        kind = extension(key)
        if kind in BINARY_TYPES:
            continue
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError:
            why: str | None = "not UTF-8 text"
        else:
            if kind == "gltf":
                why = _json_problem(text)
            elif kind in DESCRIPTION_XML_TYPES:
                why = _xml_problem(text, limits.max_elements, limits.max_depth + 8)
            elif kind in XML_TYPES:
                why = _xml_problem(text, None, None)
            else:
                why = None
        if why is not None:
            raise InvalidModel(f"asset '{shown(key)}' is unreadable as .{kind}: {why}")


def referenced_names(texts: Iterable[str]) -> set[str]:
    """The last path segment of every path-like token of `texts` (linear in their size)."""
    names: set[str] = set()
    for text in texts:
        for token in _TOKEN.findall(text):
            names.add(token.rsplit("/", 1)[-1])
    return names


def unreferenced(keys: Iterable[str], texts: Iterable[str]) -> list[str]:
    """The asset keys that no text names (by a path whose last segment is the key's file
    name: `meshes/a/x.stl` is named by `x.stl`, `a/x.stl`, `package://p/a/x.stl`, ...)."""
    names = referenced_names(texts)
    return [key for key in keys if key.rsplit("/", 1)[-1] not in names]


def asset_texts(description: str, assets: Mapping[str, bytes], *more: str) -> list[str]:
    """The description, the assets that are text (not meshes or images) and `more` (a xacro's
    expansion): where an asset may be named."""
    return [
        description,
        *more,
        *(
            data.decode("utf-8", "replace")
            for key, data in assets.items()
            if extension(key) not in (*MESH_TYPES, "png")
        ),
    ]


def missing_meshes(
    visuals: Iterable[Mapping[str, Any]], keys: Iterable[str]
) -> list[dict[str, Any]]:
    """The mesh files URDF `visuals` (entries of `visuals.urdf_visuals`) reference that are not
    among the asset `keys`: [{"file": key, "links": [link, ...]}] in document order."""
    have = set(keys)
    missing: dict[str, list[str]] = {}
    for visual in visuals:
        geometry = visual["geometry"]
        if geometry["type"] == "mesh" and geometry["asset"] not in have:
            links = missing.setdefault(geometry["asset"], [])
            if visual["frame"] not in links:
                links.append(visual["frame"])
    return [{"file": key, "links": links} for key, links in missing.items()]


def asset_report(
    description_format: str, description: str, urdf: str | None, assets: Mapping[str, bytes]
) -> dict[str, Any]:
    """What the builder reports about the assets of a built upload: `unreferenced_assets`
    (keys) and, for a URDF (a xacro: `urdf` is its expansion), `missing_meshes`."""
    more = (urdf,) if urdf is not None and urdf is not description else ()
    report: dict[str, Any] = {
        "unreferenced_assets": unreferenced(assets, asset_texts(description, assets, *more))
    }
    if description_format != "mjcf" and urdf is not None:  # MuJoCo refuses a missing mesh
        report["missing_meshes"] = missing_meshes(urdf_visuals(urdf), assets) + outside_meshes(urdf)
    return report


def outside_meshes(urdf: str) -> list[dict[str, Any]]:
    """The visual meshes of a URDF named by a path no upload can hold (absolute, a URL other
    than `package://`, climbing out with `..`): [{"file": the reference, "links": [...],
    "outside": True}]; such a visual is left out of the picture."""
    found: dict[str, list[str]] = {}
    for link in parse_bounded(urdf, MAX_ELEMENTS, MAX_DEPTH).iter("link"):
        for mesh in link.findall("visual/geometry/mesh"):
            filename = mesh.get("filename", "")
            if asset_key(filename) is None:
                links = found.setdefault(filename, [])
                if link.get("name", "") not in links:
                    links.append(link.get("name", ""))
    return [{"file": name, "links": links, "outside": True} for name, links in found.items()]
