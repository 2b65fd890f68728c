"""What `upload` sends: the description (URDF, MJCF or xacro) and the files it references.

`upload_body` takes the description as text, bytes, a file path or a directory. From a file it
collects the assets the description references, by the keys the server matches them with:

- MJCF: every `file` attribute (meshes, textures, height fields, skins, `<include>`d files, read
  recursively), joined with `<compiler meshdir/texturedir/assetdir>` as MuJoCo joins them,
  relative to the model file's directory;
- URDF and xacro: every `package://pkg/x` and `$(find pkg)/x` (key `pkg/x`, the file found in the
  nearest directory named `pkg` among the description's directory, its ancestors and their
  children) and relative mesh or include paths; included xacro and loaded YAML are read
  recursively. References computed by xacro expressions (`${...}`) are not followed: give such
  files in `assets`.

A directory stands for the one description at its top (a `.xacro`, `.urdf`, or an `.xml`/`.mjcf`
with a `<mujoco>` root). References to files that do not exist are left out (the server names
what it misses). `assets` given explicitly (key → bytes, text or a path) are added last.
"""

from __future__ import annotations

import base64
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path, PurePosixPath
from typing import Any

from robodyn.errors import InputError

Source = str | bytes | os.PathLike[str]
AssetValue = bytes | str | os.PathLike[str]
_PACKAGE = re.compile(r"package://([^\s\"'<>]+)")
_FIND = re.compile(r"\$\(find ([A-Za-z0-9_.-]+)\)(/[^\s\"'<>$]*)")
_RELATIVE = re.compile(r"(?:filename|file)=\"([^\"$:]+)\"")
_TEXT_SUFFIXES = (".xml", ".urdf", ".xacro", ".yaml", ".yml", ".mjcf", ".srdf")


def _is_text(value: str) -> bool:
    return value.lstrip().startswith("<")


def detect_format(text: str, path: Path | None = None) -> str:
    """"urdf", "mjcf" or "xacro" of a description (by its file name, else its content)."""
    if path is not None and path.name.endswith(".xacro"):
        return "xacro"
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise InputError(f"{path or 'the description'} is not well-formed XML ({exc})") from None
    if root.tag == "mujoco":
        return "mjcf"
    return "xacro" if "xacro" in text and "xmlns:xacro" in text else "urdf"


def _main_file(directory: Path) -> Path:
    candidates = sorted(p for p in directory.iterdir() if p.is_file() and (
        p.name.endswith((".xacro", ".urdf")) or (
            p.suffix in (".xml", ".mjcf") and "<mujoco" in p.read_text("utf-8", "replace"))))
    if len(candidates) != 1:
        listed = ", ".join(p.name for p in candidates) or "none"
        raise InputError(f"directory {directory} must hold exactly one description at its top "
                         f"(.xacro, .urdf, or MJCF .xml), found: {listed}; give the file")
    return candidates[0]


def _package_dir(start: Path, package: str) -> Path | None:
    for ancestor in (start, *start.parents):
        if ancestor.name == package:
            return ancestor
        if (ancestor / package).is_dir():
            return ancestor / package
    return None


def _add(assets: dict[str, bytes], key: str, path: Path, pending: list[Path]) -> None:
    key = "/".join(p for p in PurePosixPath(key).parts if p not in ("", "."))
    if key in assets or ".." in key.split("/") or not path.is_file():
        return
    assets[key] = path.read_bytes()
    if path.suffix in _TEXT_SUFFIXES:
        pending.append(path)


def _mjcf_assets(main: Path) -> dict[str, bytes]:
    base, assets = main.parent, dict[str, bytes]()
    pending, dirs = [main], {"mesh": "", "texture": "", "other": ""}
    while pending:
        root = ET.parse(pending.pop()).getroot()
        for compiler in root.iter("compiler"):
            asset_dir = compiler.get("assetdir", "")
            dirs["mesh"] = compiler.get("meshdir", dirs["mesh"] or asset_dir)
            dirs["texture"] = compiler.get("texturedir", dirs["texture"] or asset_dir)
            dirs["other"] = asset_dir or dirs["other"]
        for el in root.iter():
            file = el.get("file")
            if file is None or el is root:
                continue
            kind = ("mesh" if el.tag in ("mesh", "skin") else "texture"
                    if el.tag in ("texture", "hfield") else None)
            key = str(PurePosixPath(dirs[kind] if kind else "", file)) \
                if el.tag != "include" else file
            before = len(assets)
            _add(assets, key, base / key, [])
            if el.tag == "include" and len(assets) > before:
                pending.append(base / key)
    return assets


def _ros_assets(main: Path) -> dict[str, bytes]:
    assets: dict[str, bytes] = {}
    pending, seen = [main], set()
    while pending:
        path = pending.pop()
        if path in seen:
            continue
        seen.add(path)
        text = path.read_text("utf-8", "replace")
        references = [(m.group(1), m.group(1)) for m in _PACKAGE.finditer(text)]
        references += [(m.group(1) + m.group(2), m.group(1) + m.group(2))
                       for m in _FIND.finditer(text)]
        for key, _ in references:
            package, _, rest = key.partition("/")
            found = _package_dir(path.parent, package)
            if found is not None:
                _add(assets, key, found / rest, pending)
        for m in _RELATIVE.finditer(text):
            relative = m.group(1)
            target = (path.parent / relative).resolve()
            try:
                key = str(target.relative_to(main.parent.resolve()))
            except ValueError:
                continue
            _add(assets, key, target, pending)
    return assets


def _encode(value: AssetValue) -> str:
    if isinstance(value, os.PathLike):
        value = Path(value).read_bytes()
    if isinstance(value, str):
        value = value.encode("utf-8")
    if not isinstance(value, bytes):
        raise InputError(f"an asset must be bytes, text or a path, not {type(value).__name__}")
    return base64.b64encode(value).decode("ascii")


def upload_body(source: Source | None, *, urdf: Source | None = None,
                mjcf: Source | None = None, xacro: Source | None = None,
                assets: Mapping[str, AssetValue] | None = None,
                collect_assets: bool = True) -> dict[str, Any]:
    """The description members of an upload body: `{format: text, "assets": {...}}`."""
    given = [(fmt, v) for fmt, v in (("auto", source), ("urdf", urdf), ("mjcf", mjcf),
                                     ("xacro", xacro)) if v is not None]
    if len(given) != 1:
        raise InputError("give exactly one description (a path, a directory or the text; or "
                         "one of urdf=, mjcf=, xacro=)")
    fmt, value = given[0]
    path: Path | None = None
    if isinstance(value, os.PathLike) or (isinstance(value, str) and not _is_text(value)):
        path = Path(value)
        if path.is_dir():
            path = _main_file(path)
        if not path.is_file():
            raise InputError(f"no description file at {path}")
        text = path.read_text(encoding="utf-8")
    elif isinstance(value, bytes):
        text = value.decode("utf-8")
    elif isinstance(value, str):
        text = value
    else:
        raise InputError(f"a description is text, bytes or a path, not {type(value).__name__}")
    if fmt == "auto":
        fmt = detect_format(text, path)
    body: dict[str, Any] = {fmt: text}
    files: dict[str, str] = {}
    if path is not None and collect_assets:
        found = _mjcf_assets(path) if fmt == "mjcf" else _ros_assets(path)
        files.update({key: _encode(data) for key, data in found.items()})
    for key, data in (assets or {}).items():
        files[key] = _encode(data)
    if files:
        body["assets"] = files
    return body
