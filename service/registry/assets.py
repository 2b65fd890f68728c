"""Upload assets: the files a description references (meshes, included MJCF or xacro, YAML).

An upload's `"assets"` maps a path to the file's bytes in base64. `decode_assets` normalizes each
key (no `./`, no empty segments; `package://pkg/x` → `pkg/x`), refuses keys that are absolute,
climb with `..`, have an unknown extension, or whose bytes are empty, not base64 or not readable
as the type their extension says, and bounds their count; every refusal is an `InvalidModel`
naming the key. `AssetStore` keeps the bytes content-addressed at `<data_dir>/assets/<sha256>`
(written atomically, shared by every model that uses the same file).
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import json
import struct
from collections.abc import Iterable, Mapping
from pathlib import Path, PurePosixPath

import defusedxml.ElementTree as SafeET
from defusedxml import DefusedXmlException

from service.errors import InvalidModel
from service.registry.store import write_atomically

MAX_ASSETS = 2000
MESH_TYPES = ("stl", "obj", "dae", "glb", "gltf", "ply", "msh")
TEXT_TYPES = ("xml", "urdf", "xacro", "srdf", "yaml", "yml", "mjcf")
IMAGE_TYPES = ("png",)
OTHER_TYPES = ("skn",)  # MuJoCo skins
KNOWN_TYPES = MESH_TYPES + TEXT_TYPES + IMAGE_TYPES + OTHER_TYPES


def _shown(key: str) -> str:
    key = "".join(c if c.isprintable() else "?" for c in key)
    return key if len(key) <= 120 else key[:120] + "…"


def normalize_key(key: str) -> str:
    """The normalized relative path of an asset key or a reference to one (`InvalidModel` if
    it is absolute, climbs with `..` or is empty)."""
    text = key[len("package://"):] if key.startswith("package://") else key
    if "\\" in text or text.startswith(("/", "~")) or ":" in text or "\x00" in text:
        raise InvalidModel(f"asset '{_shown(key)}': keys are relative paths with '/' "
                           "separators (no leading '/', '~', '\\' or ':')")
    parts = [p for p in PurePosixPath(text).parts if p not in ("", ".")]
    if not parts or ".." in parts:
        raise InvalidModel(f"asset '{_shown(key)}': a key must name a file inside the upload "
                           "(no '..', not empty)")
    return "/".join(parts)


def extension(key: str) -> str:
    return PurePosixPath(key).suffix.lower().lstrip(".")


def _readable(key: str, kind: str, data: bytes) -> str | None:
    """Why `data` is not a file of type `kind`, or None."""
    if kind == "stl":
        if data[:5].lower() == b"solid" and b"facet" in data[:4096]:
            return None
        if len(data) >= 84:
            (count,) = struct.unpack_from("<I", data, 80)
            if len(data) == 84 + 50 * count:
                return None
        return "not an ASCII STL or a binary STL of the length its triangle count gives"
    if kind in ("glb",):
        return None if data[:4] == b"glTF" else "no glTF binary header"
    if kind == "ply":
        return None if data[:3] == b"ply" else "no PLY header"
    if kind == "png":
        return None if data[:8] == b"\x89PNG\r\n\x1a\n" else "no PNG signature"
    if kind in ("msh", "skn"):
        return None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return "not UTF-8 text"
    if kind == "gltf":
        try:
            json.loads(text)
        except ValueError:
            return "not JSON"
    if kind in ("dae", "xml", "urdf", "xacro", "srdf", "mjcf"):
        try:
            SafeET.fromstring(text, forbid_dtd=True, forbid_entities=True, forbid_external=True)
        except DefusedXmlException:
            return "XML with a DTD, entity or external reference"
        except (SafeET.ParseError, ValueError):
            return "not well-formed XML"
    return None


def decode_assets(encoded: Mapping[str, str] | None, max_bytes: int | None = None
                  ) -> dict[str, bytes]:
    """Validated assets (normalized key → bytes) of an upload's `"assets"` member."""
    if not encoded:
        return {}
    if len(encoded) > MAX_ASSETS:
        raise InvalidModel(f"the upload has {len(encoded)} assets; the limit is {MAX_ASSETS}")
    out: dict[str, bytes] = {}
    total = 0
    for key, value in encoded.items():
        normal = normalize_key(key)
        kind = extension(normal)
        if kind not in KNOWN_TYPES:
            raise InvalidModel(f"asset '{_shown(key)}': '.{_shown(kind)}' is not a known file "
                               f"type (known: {', '.join(KNOWN_TYPES)})")
        if normal in out:
            raise InvalidModel(f"asset '{_shown(key)}' is given twice (as '{normal}')")
        try:
            data = base64.b64decode(value, validate=True)
        except (binascii.Error, ValueError):
            raise InvalidModel(f"asset '{_shown(key)}' is not valid base64") from None
        total += len(data)
        if max_bytes is not None and total > max_bytes:
            raise InvalidModel(f"the assets hold more than {max_bytes} bytes")
        if not data:
            raise InvalidModel(f"asset '{_shown(key)}' is empty")
        why = _readable(normal, kind, data)
        if why is not None:
            raise InvalidModel(f"asset '{_shown(key)}' is unreadable as .{kind}: {why}")
        out[normal] = data
    return out


def unreferenced(assets: Iterable[str], texts: Iterable[str]) -> list[str]:
    """The asset keys that no text names by any tail of their path (`meshes/a/x.stl` is
    named by `x.stl`, `a/x.stl` or the whole key)."""
    joined = "\n".join(texts)
    out = []
    for key in assets:
        parts = key.split("/")
        if not any("/".join(parts[i:]) in joined for i in range(len(parts))):
            out.append(key)
    return out


def digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


class AssetStore:
    """Asset bytes by their SHA-256 at `<data_dir>/assets/<sha256>` (atomic writes)."""

    def __init__(self, data_dir: Path) -> None:
        self.dir = Path(data_dir) / "assets"
        self.dir.mkdir(parents=True, exist_ok=True)

    def path(self, sha: str) -> Path:
        if len(sha) != 64 or any(c not in "0123456789abcdef" for c in sha):
            raise ValueError("not a SHA-256 digest")
        return self.dir / sha

    def put(self, assets: Mapping[str, bytes]) -> dict[str, str]:
        """Store every asset (once per content): key → sha256."""
        index = {}
        for key, data in assets.items():
            sha = index[key] = digest(data)
            path = self.path(sha)
            if path.exists():
                continue
            write_atomically(path, data)
        return index

    def get(self, index: Mapping[str, str]) -> dict[str, bytes]:
        """The bytes of a record's assets (key → sha256)."""
        return {key: self.path(sha).read_bytes() for key, sha in index.items()}
