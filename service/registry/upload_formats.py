"""What each upload format (URDF, MJCF, xacro) adds around a build: the refusal of physical
findings, the record that identifies and rebuilds the model, what the builder process reports
after it (findings, notes, the served root joint, an MJCF's visuals, a xacro's expansion), and
where the assets the robot's visuals name are stored.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from service.errors import InvalidModel
from service.registry.assets import MAX_KEY_LENGTH, MESH_TYPES, AssetStore, digest, extension
from service.registry.build import Checked
from service.registry.safe_xml import shown
from service.registry.urdf_check import Finding, Limits

URDF_GRAVITY = [0.0, 0.0, -9.81]  # m/s², a URDF or xacro upload's default


def check_findings(findings: list[Finding], inertia_check: str) -> None:
    """Refuse physical findings when `inertia_check` is "reject" (the default): each names
    its link, the numbers and, where one attribute off by a power of ten explains it, the
    corrected value."""
    if findings and inertia_check == "reject":
        listed = "; ".join(f.message for f in findings[:10])
        more = len(findings) - 10
        raise InvalidModel(
            f"{listed}{f'; and {more} more' if more > 0 else ''}. Send "
            '"inertia_check": "warn" to store the model with these findings as warnings, or '
            '"repair" to store it with these inertias repaired'
        )


def new_record(
    fmt: str,
    text: str,
    root_joint: str,
    gravity: list[float] | None,
    assets: Mapping[str, bytes],
    xacro_args: Mapping[str, str] | None,
) -> dict[str, Any]:
    """The members of an upload's record that its content-derived id covers."""
    if gravity is None and fmt != "mjcf":
        gravity = URDF_GRAVITY
    record: dict[str, Any] = {
        "format": fmt,
        "description": text,
        "root_joint": root_joint,
        "gravity": None if gravity is None else list(gravity),
    }
    if assets:
        record["assets"] = {key: digest(data) for key, data in sorted(assets.items())}
    if fmt == "xacro":
        record["xacro_args"] = dict(sorted((xacro_args or {}).items()))
    return record


def after_build(
    record: dict[str, Any], report: Mapping[str, Any], model: Any, checked: Checked, limits: Limits
) -> list[dict[str, str]]:
    """Apply what the builder process reported to `record` (served root joint, visuals,
    expansion) and refuse what its caps do not admit; the upload's warnings: what validation
    found (`checked`, already accepted) and what the builder found about the assets."""
    fmt = record["format"]
    if fmt == "mjcf" and model.nv > limits.max_nv:
        raise InvalidModel(
            f"the model has nv = {model.nv} velocity coordinates; the limit is {limits.max_nv}"
        )
    if report.get("bodies", 0) > limits.max_links:
        raise InvalidModel(
            f"the model has {report['bodies']} bodies; the limit is "
            f"{limits.max_links} (ROBODYN_MAX_LINKS)"
        )
    if "root_joint" in report:
        record["served_root_joint"] = report["root_joint"]
    if fmt == "mjcf":
        record["visuals"] = report["visuals"]
    if fmt == "xacro":
        record["expanded_urdf"] = report["expanded_urdf"]
    return [*(f.as_dict() for f in checked.findings + checked.notes), *asset_warnings(report)]


def asset_warnings(report: Mapping[str, Any]) -> list[dict[str, str]]:
    """The warnings about assets the builder reported: an asset the description never names
    (`unreferenced_asset`, stored anyway) and a mesh its visuals name that is not among the
    assets (`missing_mesh`, one per file naming the links: not drawn, its URL is a 404)."""
    out = [
        {
            "code": "unreferenced_asset",
            "element": "asset",
            "name": key,
            "message": f"asset '{shown(key)}' is not named by the description or its included "
            "files; it is stored with the model",
        }
        for key in report.get("unreferenced_assets", [])
    ]
    all_missing = report.get("missing_meshes", [])
    for missing in all_missing[:MAX_MISSING_MESH_WARNINGS]:
        links = missing["links"]
        named = ", ".join(f"'{shown(link)}'" for link in links[:5])
        more = f" and {len(links) - 5} more" if len(links) > 5 else ""
        plural = "s" if len(links) > 1 else ""
        where = f"mesh '{shown(missing['file'])}' of link{plural} {named}{more}"
        message = (
            f"{where} is a path outside the upload (absolute, a URL or climbing out "
            "with '..'): it is not drawn; name it by a relative or package:// path and "
            'upload it in "assets"'
            if missing.get("outside")
            else f"{where} is not among the upload's assets: it is not drawn and GET "
            '.../assets answers 404 for it; upload it in "assets" under that key'
        )
        exact = not missing.get("outside") and len(missing["file"]) <= MAX_KEY_LENGTH
        out.append(
            {
                "code": "missing_mesh",
                "element": "link",
                "name": links[0],
                "file": missing["file"] if exact else shown(missing["file"]),
                "message": message,
            }
        )
    if len(all_missing) > MAX_MISSING_MESH_WARNINGS:
        rest = len(all_missing) - MAX_MISSING_MESH_WARNINGS
        out.append(
            {
                "code": "missing_mesh",
                "element": "link",
                "name": "",
                "message": f"and {rest} more mesh files the visuals name are missing "
                "from the upload (not listed one by one)",
            }
        )
    return out


MAX_MISSING_MESH_WARNINGS = 100
"""At most this many `missing_mesh` warnings, one per file; one more says how many others."""


def rebuild_inputs(
    record: Mapping[str, Any], store: AssetStore
) -> tuple[str, str, dict[str, bytes]]:
    """(format, text, assets) that rebuild a stored upload in the serving process: a xacro's
    stored expansion (xacro never runs there), an MJCF with its assets."""
    fmt = record.get("format", "urdf")
    if fmt == "xacro":
        return "urdf", record["expanded_urdf"], {}
    assets = store.get(record.get("assets") or {}) if fmt == "mjcf" else {}
    return fmt, record["description"], assets


def mesh_paths(store: AssetStore, record: Mapping[str, Any]) -> dict[str, Path]:
    """Asset key → stored file, for the meshes an upload's visuals name (visuals not yet
    computed, e.g. a URDF's: every mesh asset)."""
    visuals = record.get("visuals")
    named = None if visuals is None else {v["geometry"].get("asset") for v in visuals}
    return {
        key: store.path(sha)
        for key, sha in (record.get("assets") or {}).items()
        if extension(key) in MESH_TYPES and (named is None or key in named)
    }


REBUILD_KEYS = (
    "format",
    "description",
    "root_joint",
    "gravity",
    "assets",
    "served_root_joint",
    "xacro_args",
    "expanded_urdf",
    "visuals",
    "inertia_repairs",
)
