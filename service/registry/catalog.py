"""Loading the catalog (`robots/catalog.toml`) the way example-robot-data's loader did.

Free-flyer bases get position limits [-1, 1] on their 7 q entries; SRDF reference postures are
read; with `rotor_parameters` the armature is rotor inertia × gear ratio² (Talos). A robot that
fails to load is reported (name and reason) and the rest of the catalog still serves.
"""

from __future__ import annotations

import logging
import sys
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from robots import CATALOG_DIR, CATALOG_FILE
from service.registry.build import build_urdf_model
from service.registry.check_inputs import CheckInputs, catalog_inputs
from service.registry.robot import Robot
from service.registry.urdf_check import check_urdf
from service.registry.visuals import on_model, resolve_assets, urdf_visuals

log = logging.getLogger("robodyn.catalog")


def erd_robots_dir() -> Path:
    """The `robots/` directory of the installed example-robot-data package."""
    for entry in sys.path:
        for candidate in (
            Path(entry) / "cmeel.prefix" / "share" / "example-robot-data",
            Path(entry) / ".." / ".." / ".." / "share" / "example-robot-data",
        ):
            if (candidate / "robots").is_dir():
                return (candidate / "robots").resolve()
    raise FileNotFoundError("the example-robot-data package is not installed")


@dataclass(frozen=True)
class CatalogEntry:
    name: str
    spec: dict[str, Any]

    def path(self, key: str) -> Path:
        base = CATALOG_DIR if self.spec.get("bundled") else erd_robots_dir()
        path: Path = base / self.spec[key]
        return path


def catalog_entries() -> list[CatalogEntry]:
    with CATALOG_FILE.open("rb") as fh:
        table = tomllib.load(fh)["robots"]
    return [CatalogEntry(name, spec) for name, spec in sorted(table.items())]


_VELOCITY_EFFORT_BOUNDS = (
    "lowerVelocityLimit",
    "upperVelocityLimit",
    "lowerEffortLimit",
    "upperEffortLimit",
)


def _keep_joints_below(model: Any, limit: int) -> Any:
    """A copy of `model` with only joints of index < limit (the loader's talos_legs)."""
    reduced = pin.Model()
    for jid in range(1, min(limit, model.njoints)):
        jm = model.joints[jid]
        new = reduced.addJoint(model.parents[jid], jm, model.jointPlacements[jid], model.names[jid])
        nq, nv = jm.nq, jm.nv
        rq, rv = reduced.joints[new].idx_q, reduced.joints[new].idx_v
        for attr, (src, dst, n) in {
            "upperPositionLimit": (jm.idx_q, rq, nq),
            "lowerPositionLimit": (jm.idx_q, rq, nq),
            "velocityLimit": (jm.idx_v, rv, nv),
            "effortLimit": (jm.idx_v, rv, nv),
            # Pinocchio ≥ 3.4 also keeps lower bounds (addJoint leaves them at +max, which
            # its model reduction refuses as lower > upper)
            **{
                name: (jm.idx_v, rv, nv) for name in _VELOCITY_EFFORT_BOUNDS if hasattr(model, name)
            },
        }.items():
            values = getattr(reduced, attr)
            values[dst : dst + n] = getattr(model, attr)[src : src + n]
            setattr(reduced, attr, values)
        reduced.appendBodyToJoint(new, model.inertias[jid], pin.SE3.Identity())
    for frame in model.frames:
        if 0 < frame.parentJoint < limit:
            reduced.addFrame(frame)
    effort = reduced.effortLimit
    effort[:6] = np.inf
    reduced.effortLimit = effort
    return reduced


def load_entry(entry: CatalogEntry) -> Robot:
    """Load one catalog robot into a `Robot`; raises on any failure."""
    spec = entry.spec
    root_joint = spec.get("root_joint", "fixed")
    if "urdf" not in spec:
        if not getattr(pin, "WITH_SDFORMAT", False):
            raise RuntimeError("SDF description; this Pinocchio build has no SDFormat support")
        raise RuntimeError("SDF catalog entries are not supported yet")
    text = entry.path("urdf").read_text(encoding="utf-8")
    findings = check_urdf(text, lenient=True).findings
    model = build_urdf_model(text, root_joint)
    if "root_rotation" in spec:
        placement = model.jointPlacements[1]
        placement.rotation = np.asarray(spec["root_rotation"], dtype=float)
        model.jointPlacements[1] = placement
    if "keep_joints_below" in spec:
        model = _keep_joints_below(model, int(spec["keep_joints_below"]))
    references: dict[str, np.ndarray] = {}
    default = pin.neutral(model)
    if "srdf" in spec:
        srdf = str(entry.path("srdf"))
        if spec.get("rotor_parameters"):
            pin.loadRotorParameters(model, srdf, False)
        model.armature = np.multiply(
            np.asarray(model.rotorInertia).flat, np.square(np.asarray(model.rotorGearRatio).flat)
        )
        pin.loadReferenceConfigurations(model, srdf, False)
        references = {
            e.key(): pin.normalize(model, np.array(e.data())) for e in model.referenceConfigurations
        }
        posture = spec.get("reference_posture")
        if posture is not None and posture in references:
            default = references[posture].copy()
    if root_joint == "free-flyer":
        upper, lower = model.upperPositionLimit, model.lowerPositionLimit
        upper[:7], lower[:7] = 1.0, -1.0
        model.upperPositionLimit, model.lowerPositionLimit = upper, lower
    contact_type = spec.get("contact_type", "point")
    contacts = [{"frame": frame, "type": contact_type} for frame in spec.get("contact_frames", [])]
    visuals, asset_paths = _visuals(entry, text, model)
    return Robot(
        id=entry.name,
        name=entry.name,
        source="catalog",
        root_joint=root_joint,
        model=model,
        reference_configurations=references,
        default_configuration=default,
        warnings=[f.as_dict() for f in findings],
        contact_frames=contacts,
        visuals=visuals,
        asset_paths=asset_paths,
    )


def _visuals(
    entry: CatalogEntry, text: str, model: Any
) -> tuple[list[dict[str, Any]], dict[str, Path]]:
    """The robot's visuals and the mesh files they name (inside example-robot-data); none,
    logged, if the description's visuals cannot be read: the dynamics still serve."""
    body_frames = {f.name for f in model.frames if f.type == pin.FrameType.BODY}
    try:
        return resolve_assets(
            on_model(urdf_visuals(text), body_frames.__contains__),
            package_root=erd_robots_dir().parent.parent,
            description_dir=entry.path("urdf").parent,
        )
    except Exception as exc:
        log.warning("catalog robot %r: visuals not read (%s)", entry.name, exc)
        return [], {}


def catalog_check_inputs(name: str, model: Any, repairs: Sequence[dict[str, Any]]) -> CheckInputs:
    """What the model check of catalog robot `name` (served as `model`, with the inertia
    `repairs` of the variants between) reads: its description file and mesh directories."""
    entry = next(e for e in catalog_entries() if e.name == name)
    return catalog_inputs(
        entry.path("urdf").read_text(encoding="utf-8"),
        entry.spec.get("root_joint", "fixed"),
        model,
        [erd_robots_dir().parent.parent, entry.path("urdf").parent],
        repairs,
    )


def load_catalog(names: list[str] | None = None) -> tuple[dict[str, Robot], dict[str, str]]:
    """Load the catalog (or the named part of it): (robots by id, failures by name → reason)."""
    robots: dict[str, Robot] = {}
    failures: dict[str, str] = {}
    entries = catalog_entries()
    if names is not None:
        known = {e.name for e in entries}
        for name in names:
            if name not in known:
                failures[name] = "not in the catalog"
        entries = [e for e in entries if e.name in names]
    for entry in entries:
        try:
            robots[entry.name] = load_entry(entry)
        except Exception as exc:
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            failures[entry.name] = reason
            log.warning("catalog robot %r not loaded: %s", entry.name, reason)
    return robots, failures
