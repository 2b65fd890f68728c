"""Upload assets: the files a description references (meshes, included MJCF or xacro, YAML).

An upload's `"assets"` maps a path to the file's bytes in base64. `decode_assets` (in the serving
process, linear in the upload's size) normalizes each key (no `./`, no empty segments;
`package://pkg/x` → `pkg/x`), refuses keys that are absolute, climb with `..`, are longer than
`MAX_KEY_LENGTH` characters or `MAX_KEY_SEGMENTS` segments, have an unknown extension, or whose
bytes are empty, not base64 or (binary types: STL, glb, PLY, PNG) lack their format's header, and
bounds their count; every refusal is an `InvalidModel` naming the key. Text assets (XML, glTF
JSON, YAML) are read only in the builder process (`service.registry.asset_checks`): parsing them
here would hold this process's GIL and memory for as long as the file is large. `AssetStore`
keeps the bytes content-addressed at `<data_dir>/assets/<sha256>` (written atomically, shared by
every model that uses the same file) and removes the files no stored model names any more
(`collect`).
"""

from __future__ import annotations

import base64
import binascii
import contextlib
import fcntl
import hashlib
import logging
import os
import struct
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path, PurePosixPath

from service.errors import InvalidModel
from service.registry.store import STALE_TMP_S, write_atomically

log = logging.getLogger("robodyn.assets")

MAX_ASSETS = 2000
MAX_KEY_LENGTH = 1024
"""The longest asset key (characters, after normalization): far more than any real path."""
MAX_KEY_SEGMENTS = 32
"""The most path segments of an asset key (`a/b/c.stl` has 3)."""
MESH_TYPES = ("stl", "obj", "dae", "glb", "gltf", "ply", "msh")
TEXT_TYPES = ("xml", "urdf", "xacro", "srdf", "yaml", "yml", "mjcf")
IMAGE_TYPES = ("png",)
OTHER_TYPES = ("skn",)  # MuJoCo skins
KNOWN_TYPES = MESH_TYPES + TEXT_TYPES + IMAGE_TYPES + OTHER_TYPES


def _shown(key: str) -> str:
    shown = "".join(c if c.isprintable() else "?" for c in key[:120])
    return shown if len(key) <= 120 else shown + "…"


def normalize_key(key: str) -> str:
    """The normalized relative path of an asset key or a reference to one (`InvalidModel` if
    it is absolute, climbs with `..` or is empty)."""
    text = key[len("package://") :] if key.startswith("package://") else key
    if "\\" in text or text.startswith(("/", "~")) or ":" in text or "\x00" in text:
        raise InvalidModel(
            f"asset '{_shown(key)}': keys are relative paths with '/' "
            "separators (no leading '/', '~', '\\' or ':')"
        )
    if len(text) > 4 * MAX_KEY_LENGTH:  # before splitting it (`./` segments are dropped)
        raise InvalidModel(
            f"asset '{_shown(key)}': the key is {len(text)} characters long; "
            f"the limit is {MAX_KEY_LENGTH}"
        )
    parts = [p for p in PurePosixPath(text).parts if p not in ("", ".")]
    if not parts or ".." in parts:
        raise InvalidModel(
            f"asset '{_shown(key)}': a key must name a file inside the upload (no '..', not empty)"
        )
    if len(parts) > MAX_KEY_SEGMENTS:
        raise InvalidModel(
            f"asset '{_shown(key)}': the key has {len(parts)} path segments; "
            f"the limit is {MAX_KEY_SEGMENTS}"
        )
    normal = "/".join(parts)
    if len(normal) > MAX_KEY_LENGTH:
        raise InvalidModel(
            f"asset '{_shown(key)}': the key is {len(normal)} characters long; "
            f"the limit is {MAX_KEY_LENGTH}"
        )
    return normal


def extension(key: str) -> str:
    return PurePosixPath(key).suffix.lower().lstrip(".")


def _readable(kind: str, data: bytes) -> str | None:
    """Why `data` is not a file of binary type `kind`, or None (constant time: headers and
    lengths only). Text types are read in the builder process (`asset_checks`)."""
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
    return None


def decode_assets(
    encoded: Mapping[str, str] | None, max_bytes: int | None = None
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
            raise InvalidModel(
                f"asset '{_shown(key)}': '.{_shown(kind)}' is not a known file "
                f"type (known: {', '.join(KNOWN_TYPES)})"
            )
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
        why = _readable(kind, data)
        if why is not None:
            raise InvalidModel(f"asset '{_shown(key)}' is unreadable as .{kind}: {why}")
        out[normal] = data
    return out


def digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


class AssetStore:
    """Asset bytes by their SHA-256 at `<data_dir>/assets/<sha256>` (atomic writes).

    Files are shared by every model whose record names them, so a deletion removes only the
    files no remaining record names (`collect`, a mark and sweep). An upload holds a shared
    lock on `<data_dir>/assets/.lock` from `put` until its record is written (`storing`), and
    `collect` an exclusive one, so a file is never swept between being stored and being named
    (an `flock`: processes and replicas sharing the directory on one host are covered)."""

    def __init__(self, data_dir: Path) -> None:
        self.dir = Path(data_dir) / "assets"
        self.dir.mkdir(parents=True, exist_ok=True)

    def path(self, sha: str) -> Path:
        if len(sha) != 64 or any(c not in "0123456789abcdef" for c in sha):
            raise ValueError("not a SHA-256 digest")
        return self.dir / sha

    @contextmanager
    def _locked(self, exclusive: bool) -> Iterator[None]:
        fd = os.open(self.dir / ".lock", os.O_RDWR | os.O_CREAT, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
            yield
        finally:
            os.close(fd)  # releases the lock

    def storing(self) -> contextlib.AbstractContextManager[None]:
        """Hold while storing assets and writing the record that names them."""
        return self._locked(exclusive=False)

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

    def collect(self, referenced: Callable[[], Iterable[str]]) -> int:
        """Remove every stored file whose SHA-256 is not in `referenced()` (called under the
        exclusive lock, so it sees every record written before) and temporary files of writes
        that died; the bytes freed. Blocking."""
        freed = 0
        with self._locked(exclusive=True):
            keep = set(referenced())
            now = time.time()
            for path in self.dir.iterdir():
                name = path.name
                try:
                    if name.startswith(".tmp-"):
                        if now - path.stat().st_mtime < STALE_TMP_S:
                            continue  # a write in progress (stores do not take the lock)
                    elif name.startswith(".") or name in keep:
                        continue
                    size = path.stat().st_size
                    path.unlink()
                    freed += size
                except OSError:  # removed meanwhile by another process
                    continue
        if freed:
            log.info("removed %d bytes of assets no stored model names", freed)
        return freed
