"""The durable, content-addressed store of uploaded models.

One JSON record per model at `<data_dir>/models/<id>.json` holding what is needed to rebuild it
(the description text and the upload options; for a variant its modifications and its lineage,
`service.registry.lineage`) plus its summary. Writes are atomic: write a temporary file, fsync,
rename over the final name, fsync the directory. A record is therefore either absent or
complete; an unreadable one, or one that is valid JSON but incomplete (checked against the
schema of `service.registry.records`), is skipped with one log line. Temporary files left by
a process killed in the middle of a write are never read as records (their names start with a
dot) and are removed when a store opens and finds them older than a minute.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import re
import tempfile
import time
from pathlib import Path
from typing import Any

from service.registry.records import check_record

log = logging.getLogger("robodyn.store")

_ID = re.compile(r"^[a-z0-9][a-z0-9_-]{0,63}$")
STALE_TMP_S = 60.0  # a temporary file this old belongs to a write that died


def content_id(record: dict[str, Any]) -> str:
    """The id of an upload: a hash of its description and the options that change the model.

    The same upload gives the same id on any machine, so uploads are idempotent and replicas
    agree on ids. It covers the assets (by content), a xacro's arguments and the inertia repairs
    of `inertia_check: "repair"` (a repaired model is another model). The label (`name`)
    and `inertia_check` do not change the dynamics and are not part of it.
    """
    gravity = record["gravity"]  # None: the description's own (MJCF)
    identity = {
        "format": record["format"],
        "description": record["description"],
        "root_joint": record["root_joint"],
        "gravity": None if gravity is None else [float(g) for g in gravity],
    }
    if record.get("assets"):  # key → sha256 of the bytes; absent for uploads without assets
        identity["assets"] = dict(sorted(record["assets"].items()))
    if record.get("inertia_repairs"):  # `inertia_check: "repair"` changed the inertials
        identity["inertia_repairs"] = record["inertia_repairs"]
    if record["format"] == "xacro":
        identity["xacro_args"] = dict(sorted(record.get("xacro_args", {}).items()))
    canonical = json.dumps(identity, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return "u-" + hashlib.sha256(canonical.encode("utf-8")).hexdigest()[:24]


def reduced_id(base_id: str, locked_joints: dict[str, list[float]]) -> str:
    """The id of a reduced model: a hash of its base's id and the locked joints as requested
    (joint name → list of numbers). Base ids are themselves content-derived (or catalog names),
    so the same reduction gives the same id on any machine."""
    canonical = json.dumps(
        {
            "format": "reduced",
            "base": base_id,
            "locked_joints": {k: [float(x) for x in v] for k, v in sorted(locked_joints.items())},
        },
        sort_keys=True,
        separators=(",", ":"),
        ensure_ascii=False,
    )
    return "r-" + hashlib.sha256(canonical.encode("utf-8")).hexdigest()[:24]


def write_atomically(path: Path, payload: bytes) -> None:
    """Write `payload` to `path` so that readers see the old file or the whole new one: a
    temporary file in the same directory (its name starts with a dot), fsync, rename over
    `path`, fsync the directory."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(payload)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    dir_fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


class ModelStore:
    """Records of uploaded models in one directory, shared safely by processes and replicas."""

    def __init__(self, data_dir: Path) -> None:
        self.dir = Path(data_dir) / "models"
        self.dir.mkdir(parents=True, exist_ok=True)
        self._reported: set[str] = set()  # ids of unreadable records already logged
        self._remove_stale_temporaries()

    def _remove_stale_temporaries(self) -> None:
        now = time.time()
        for tmp in self.dir.glob(".tmp-*.json"):
            try:
                if now - tmp.stat().st_mtime > STALE_TMP_S:
                    tmp.unlink()
                    log.warning("removed %s, left by an interrupted write", tmp.name)
            except OSError:  # removed meanwhile by another process
                pass

    def _path(self, model_id: str) -> Path | None:
        return self.dir / f"{model_id}.json" if _ID.match(model_id) else None

    def exists(self, model_id: str) -> bool:
        path = self._path(model_id)
        return path is not None and path.exists()

    def read(self, model_id: str) -> dict[str, Any] | None:
        path = self._path(model_id)
        if path is None:
            return None
        try:
            with path.open("rb") as fh:
                record = json.loads(fh.read())
            return check_record(record, model_id)
        except FileNotFoundError:
            return None
        except (OSError, ValueError) as exc:
            if model_id not in self._reported:  # records never change: one line per record
                self._reported.add(model_id)
                log.error("skipping unreadable model record %s: %s", path.name, exc)
            return None

    def write(self, record: dict[str, Any]) -> None:
        path = self._path(record["id"])
        if path is None:
            raise ValueError("invalid model id")
        write_atomically(path, json.dumps(record, ensure_ascii=False).encode("utf-8"))

    def delete(self, model_id: str) -> bool:
        path = self._path(model_id)
        if path is None:
            return False
        try:
            path.unlink()
        except FileNotFoundError:
            return False
        return True

    def ids(self) -> list[str]:
        return sorted(p.stem for p in self.dir.glob("*.json") if _ID.match(p.stem))
