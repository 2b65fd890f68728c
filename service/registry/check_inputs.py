"""What the model check of a robot reads, gathered from what the registry holds: its root
description (a catalog robot's URDF file, an upload's URDF text, a xacro's expansion, or an
MJCF upload's text, compiled by MuJoCo where the check runs: `mjcf_links`), where its meshes
are, and the inertia repairs along its lineage (the upload's own, then each variant's).

A model whose bodies were replaced by identified parameters is checked on its model's bodies
(`model_links`): one link per joint, named by the first body frame the joint carries, with the
root description's geometry of every link that joint carries, placed in that frame
(`joint_frames`): the shapes are the description's, only the inertials were identified.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from service.registry.assets import AssetStore, extension
from service.registry.link_descriptions import LinkDescription, ShapeElement, link_descriptions
from service.registry.link_inertias import repaired_links
from service.registry.meshes import Triangles, read_mesh, read_mesh_file
from service.registry.records import VARIANT_FORMATS

JointFrames = dict[str, tuple[str, np.ndarray, np.ndarray]]
"""Link (body frame) → (the first body frame of its joint, the link frame's rotation 3×3 and
translation [3] m in that frame)."""


@dataclass(frozen=True)
class CheckInputs:
    """The description's URDF or MJCF (`mjcf`; neither: no geometry), its root joint, the body
    frames of the served model (links outside it, e.g. a reduced catalog model's, are not
    checked), the repairs along the lineage, and the files: by key, `mesh_data` (bytes, an
    upload being stored), `mesh_files` (key → (file, type), stored assets) or under
    `mesh_roots` (directories a catalog description's keys are looked up in). With
    `joint_frames` (an identified model), the links checked are `model_links`, with the
    description's geometry (module docstring)."""

    urdf: str | None
    root_joint: str
    body_names: frozenset[str]
    repairs: tuple[dict[str, Any], ...] = ()
    model_links: tuple[LinkDescription, ...] = ()
    mesh_data: dict[str, bytes] = field(default_factory=dict)
    mesh_files: dict[str, tuple[str, str]] = field(default_factory=dict)
    mesh_roots: tuple[str, ...] = ()
    mjcf: str | None = None
    joint_frames: JointFrames | None = None

    def links(self) -> list[LinkDescription]:
        """The links to check: the description's on the model, with the repairs applied; or,
        for an identified model, `model_links` with the description's geometry."""
        described = [link for link in self._described() if link.name in self.body_names]
        if self.joint_frames is not None:
            return joint_links(self.model_links, described, self.joint_frames)
        return repaired_links(described, self.repairs)

    def _described(self) -> list[LinkDescription]:
        if self.mjcf is not None:
            return self._compiled_mjcf[0]
        if self.urdf is not None:
            return link_descriptions(self.urdf, self.root_joint)
        return []

    @functools.cached_property
    def _compiled_mjcf(self) -> tuple[list[LinkDescription], dict[str, Triangles | None]]:
        """The MJCF's links and meshes, compiled by MuJoCo with the upload's files (here, in
        the check's child process: MuJoCo parses untrusted files)."""
        from service.registry.mjcf_build import pinocchio_model
        from service.registry.mjcf_compile import compile_mjcf
        from service.registry.mjcf_links import mjcf_links, mjcf_meshes

        assert self.mjcf is not None
        files = dict(self.mesh_data)
        for key, (path, _) in self.mesh_files.items():
            files.setdefault(key, Path(path).read_bytes())
        mj = compile_mjcf(self.mjcf, files)
        frames = pinocchio_model(mj, self.root_joint).body_frames
        return mjcf_links(mj, frames, self.root_joint), dict(mjcf_meshes(mj))

    def read_mesh(self, key: str) -> Triangles | None:
        """The triangles of the mesh `key` names (None: not found or unreadable)."""
        kind = extension(key)
        if self.mjcf is not None:
            return self._compiled_mjcf[1].get(key)
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


def _moved(element: ShapeElement, rotation: np.ndarray, translation: np.ndarray) -> ShapeElement:
    r, t, geometry = element
    return rotation @ r, rotation @ t + translation, geometry


def joint_links(
    links: Sequence[LinkDescription], described: Sequence[LinkDescription], frames: JointFrames
) -> list[LinkDescription]:
    """`links` (one per joint, named by its first body frame) with the geometry of every
    described link its joint carries, placed in that frame: their collision elements if every
    one of them with a shape has some, their visual ones likewise (else none of that source:
    part of a body's shape would give a wrong volume)."""
    carried: dict[str, list[LinkDescription]] = {}
    for link in described:
        if link.name in frames and (link.collision or link.visual):
            carried.setdefault(frames[link.name][0], []).append(link)
    out = []
    for link in links:
        parts = carried.get(link.name, [])
        sources: dict[str, list[ShapeElement]] = {"collision": [], "visual": []}
        for source, elements in sources.items():
            if all(getattr(part, source) for part in parts):
                for part in parts:
                    _, rotation, translation = frames[part.name]
                    elements += [_moved(e, rotation, translation) for e in getattr(part, source)]
        out.append(
            dataclasses.replace(link, collision=sources["collision"], visual=sources["visual"])
        )
    return out


def joint_frames(model: Any) -> JointFrames:
    """Each body frame of `model` → the first body frame of its joint (`model_links`' names)
    and its placement in that one."""
    first: dict[int, Any] = {}
    out: JointFrames = {}
    for frame in model.frames:
        if frame.type != pin.FrameType.BODY:
            continue
        head = first.setdefault(int(frame.parentJoint), frame)
        relative = head.placement.actInv(frame.placement)
        out[frame.name] = (
            head.name,
            np.array(relative.rotation, dtype=float),
            np.array(relative.translation, dtype=float),
        )
    return out


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
    text = description.get("expanded_urdf") if fmt == "xacro" else description.get("description")
    files = {}
    if assets is not None:
        files = {
            key: (str(assets.path(sha)), extension(key))
            for key, sha in (description.get("assets") or {}).items()
        }
    return CheckInputs(
        urdf=None if fmt == "mjcf" else text,
        root_joint=str(description.get("root_joint", "fixed")),
        body_names=body_names(model),
        repairs=tuple(repairs),
        mesh_data=dict(mesh_data or {}),
        mesh_files=files,
        mjcf=text if fmt == "mjcf" else None,
    )


def identified_inputs(described: CheckInputs, model: Any) -> CheckInputs:
    """The inputs of an identified model `model` whose root description `described` reads:
    its bodies (`model_links`) with the description's geometry."""
    return dataclasses.replace(
        described,
        body_names=body_names(model),
        repairs=(),
        model_links=model_links(model),
        joint_frames=joint_frames(model),
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
