"""Reading a mesh file's triangles for the model check, with trimesh (STL, OBJ, PLY, GLB/glTF,
COLLADA through pycollada): every format uploads accept but MuJoCo's own `.msh`.

A file holding several meshes (a COLLADA or glTF scene) gives their union with each node's
transform applied (trimesh's `force="mesh"`), in the file's own units; vertices that coincide
are merged, so `closed` (every edge shared by exactly two triangles with consistent winding:
a watertight surface, what the divergence theorem needs) can be judged. Parsing only: the mass
properties are `service.dynamics.model_check.geometry`'s.
"""

from __future__ import annotations

import io
import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

log = logging.getLogger("robodyn.meshes")

READABLE = ("stl", "obj", "ply", "glb", "gltf", "dae")


@dataclass(frozen=True)
class Triangles:
    """A triangle mesh: `vertices` (n, 3) in the file's units, `faces` (m, 3) vertex indices
    (counter-clockwise seen from outside where the file is consistent), `closed` as above."""

    vertices: np.ndarray
    faces: np.ndarray
    closed: bool


def read_mesh(data: bytes, file_type: str) -> Triangles | None:
    """The triangles of a mesh file's bytes (`file_type`: its extension), None if trimesh
    cannot read it as a mesh with at least one triangle."""
    import trimesh  # imported on first use: the serving process never reads a mesh itself

    kind = file_type.lower()
    if kind not in READABLE:
        return None
    try:
        mesh = trimesh.load(io.BytesIO(data), file_type=kind, force="mesh", process=True)
    except Exception as exc:  # a file trimesh cannot read: no geometry from it
        log.info("mesh not read (%s): %s", kind, type(exc).__name__)
        return None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        return None
    return Triangles(
        vertices=np.asarray(mesh.vertices, dtype=float),
        faces=np.asarray(mesh.faces, dtype=np.int64),
        closed=bool(mesh.is_watertight and mesh.is_winding_consistent),
    )


def read_mesh_file(path: Path, file_type: str | None = None) -> Triangles | None:
    """`read_mesh` of a file on disk (a catalog robot's, or a stored asset); `file_type`
    defaults to the file's extension."""
    try:
        data = path.read_bytes()
    except OSError:
        return None
    return read_mesh(data, file_type or path.suffix.lstrip("."))
