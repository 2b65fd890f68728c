"""What the model check of a robot reads, gathered from what the registry holds: the URDF of its
root description (a catalog file, an upload's text or a xacro's expansion), where its meshes
are, and the inertia repairs along its lineage (the upload's own, then each variant's).

A model without a URDF (an MJCF upload) or whose bodies were replaced by identified parameters
is checked on its model's bodies instead (`model_links`): one link per joint, named by the first
body frame the joint carries, with no geometry.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from service.registry.assets import AssetStore, extension
from service.registry.link_descriptions import LinkDescription, link_descriptions
from service.registry.link_inertias import repaired_links
from service.registry.meshes import Triangles, read_mesh, read_mesh_file
from service.registry.records import VARIANT_FORMATS


@dataclass(frozen=True)
class CheckInputs:
    """The description's URDF (None: check `model_links`), its root joint, the body frames of
    the served model (links outside it, e.g. a reduced catalog model's, are not checked), the
    repairs along the lineage, and the meshes: by key, `mesh_data` (bytes, an upload being
    stored), `mesh_files` (key → (file, type), stored assets) or under `mesh_roots`
    (directories a catalog description's keys are looked up in)."""

    urdf: str | None
    root_joint: str
    body_names: frozenset[str]
    repairs: tuple[dict[str, Any], ...] = ()
    model_links: tuple[LinkDescription, ...] = ()
    mesh_data: dict[str, bytes] = field(default_factory=dict)
    mesh_files: dict[str, tuple[str, str]] = field(default_factory=dict)
    mesh_roots: tuple[str, ...] = ()

    def links(self) -> list[LinkDescription]:
        """The links to check: the URDF's on the model, with the repairs applied."""
        if self.urdf is None:
            return list(self.model_links)
        described = link_descriptions(self.urdf, self.root_joint)
        on_model = [link for link in described if link.name in self.body_names]
        return repaired_links(on_model, self.repairs)

    def read_mesh(self, key: str) -> Triangles | None:
        """The triangles of the mesh `key` names (None: not found or unreadable)."""
        kind = extension(key)
        if key in self.mesh_data:
            return read_mesh(self.mesh_data[key], kind)
        if key in self.mesh_files:
            path, kind = self.mesh_files[key]
            return read_mesh_file(Path(path), kind)
        for root in self.mesh_roots:
            base = Path(root).resolve()
            candidate = (base / key).resolve()
            if candidate.is_relative_to(base) and candidate.is_file():
                return read_mesh_file(candidate, kind)
        return None


def body_names(model: Any) -> frozenset[str]:
    return frozenset(f.name for f in model.frames if f.type == pin.FrameType.BODY)


def model_links(model: Any) -> tuple[LinkDescription, ...]:
    """One link per joint of `model`: its body's inertial in the frame of the first body frame
    the joint carries (named after it), moving, without geometry."""
    out = []
    for joint in range(1, model.njoints):
        frame = next(
            (f for f in model.frames if f.parentJoint == joint and f.type == pin.FrameType.BODY),
            None,
        )
        if frame is None:
            continue
        body = frame.placement.actInv(model.inertias[joint])
        out.append(
            LinkDescription(
                name=frame.name,
                mass=float(body.mass),
                center_of_mass=np.array(body.lever, dtype=float),
                inertia=np.array(body.inertia, dtype=float),
                attributes=None,
                moves=True,
            )
        )
    return tuple(out)


def lineage_repairs(record: Mapping[str, Any]) -> tuple[dict[str, Any], ...]:
    """The inertia repairs of a stored record: its root's, each step's, then its own."""
    repairs: list[dict[str, Any]] = []
    if record.get("format") in VARIANT_FORMATS:
        base = record.get("base") or {}
        repairs += (base.get("record") or {}).get("inertia_repairs") or []
        for step in record.get("steps") or []:
            repairs += step.get("inertia_repairs") or []
    repairs += record.get("inertia_repairs") or []
    return tuple(repairs)


def fitted_lineage(record: Mapping[str, Any]) -> bool:
    """Whether identified inertial parameters replaced the bodies somewhere in the lineage."""
    steps: Sequence[Mapping[str, Any]] = record.get("steps") or []
    return any(s.get("inertial_parameters") is not None for s in [*steps, record])


def upload_inputs(
    description: Mapping[str, Any],
    model: Any,
    repairs: Sequence[dict[str, Any]],
    *,
    assets: AssetStore | None = None,
    mesh_data: Mapping[str, bytes] | None = None,
) -> CheckInputs:
    """The inputs of an uploaded description's record (`description`: its format, text or
    expansion, root joint and assets), its meshes stored in `assets` or given as bytes."""
    fmt = description.get("format", "urdf")
    urdf = description.get("expanded_urdf") if fmt == "xacro" else description.get("description")
    files = {}
    if assets is not None:
        files = {
            key: (str(assets.path(sha)), extension(key))
            for key, sha in (description.get("assets") or {}).items()
        }
    return CheckInputs(
        urdf=None if fmt == "mjcf" else urdf,
        root_joint=str(description.get("root_joint", "fixed")),
        body_names=body_names(model),
        repairs=tuple(repairs),
        model_links=model_links(model) if fmt == "mjcf" else (),
        mesh_data=dict(mesh_data or {}),
        mesh_files=files,
    )


def catalog_inputs(
    urdf: str, root_joint: str, model: Any, roots: Sequence[Path], repairs: Sequence[dict[str, Any]]
) -> CheckInputs:
    """The inputs of a catalog robot (its description file's text, its mesh directories)."""
    return CheckInputs(
        urdf=urdf,
        root_joint=root_joint,
        body_names=body_names(model),
        repairs=tuple(repairs),
        mesh_roots=tuple(str(r) for r in roots),
    )
