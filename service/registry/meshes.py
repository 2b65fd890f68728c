"""Reading a mesh file's triangles for the model check: with trimesh (STL, OBJ, PLY, GLB/glTF,
COLLADA through pycollada), and MuJoCo's own `.msh` through MuJoCo's compiler (the mesh alone
in a one-geom model; its vertices put back from the frame MuJoCo moves them to, the mesh's
`mesh_pos`, `mesh_quat`, into the file's own): every mesh format uploads accept.

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

READABLE = ("stl", "obj", "ply", "glb", "gltf", "dae", "msh")
_MSH_MODEL = (
    '<mujoco><asset><mesh name="m" file="m.msh" inertia="shell"/></asset>'
    '<worldbody><geom type="mesh" mesh="m"/></worldbody></mujoco>'
)


@dataclass(frozen=True)
class Triangles:
    """A triangle mesh: `vertices` (n, 3) in the file's units, `faces` (m, 3) vertex indices
    (counter-clockwise seen from outside where the file is consistent), `closed` as above."""

    vertices: np.ndarray
    faces: np.ndarray
    closed: bool


def closed_triangles(vertices: np.ndarray, faces: np.ndarray) -> Triangles | None:
    """`Triangles` of vertices (n, 3) and faces (m, 3), coinciding vertices merged so that
    `closed` can be judged; None without a triangle."""
    import trimesh  # imported on first use: the serving process never reads a mesh itself

    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=True)
    if len(mesh.faces) == 0:
        return None
    return Triangles(
        vertices=np.asarray(mesh.vertices, dtype=float),
        faces=np.asarray(mesh.faces, dtype=np.int64),
        closed=bool(mesh.is_watertight and mesh.is_winding_consistent),
    )


def _msh_triangles(data: bytes) -> Triangles | None:
    """A MuJoCo `.msh` file's triangles, read by MuJoCo's compiler, in the file's frame."""
    from service.errors import InvalidModel
    from service.registry.mjcf_build import se3
    from service.registry.mjcf_compile import compile_mjcf  # MuJoCo's warnings to the log

    try:
        mj = compile_mjcf(_MSH_MODEL, {"m.msh": data})
    except InvalidModel as exc:  # MuJoCo cannot read it (or it bounds no surface)
        log.info("mesh not read (msh): %s", exc.detail[:200])
        return None
    frame = se3(mj.mesh_quat[0], mj.mesh_pos[0])
    vertices = np.asarray(mj.mesh_vert, dtype=float) @ np.asarray(frame.rotation).T
    vertices += np.asarray(frame.translation)
    return closed_triangles(vertices, np.asarray(mj.mesh_face, dtype=np.int64))


def read_mesh(data: bytes, file_type: str) -> Triangles | None:
    """The triangles of a mesh file's bytes (`file_type`: its extension), None if it cannot be
    read as a mesh with at least one triangle."""
    import trimesh  # imported on first use: the serving process never reads a mesh itself

    kind = file_type.lower()
    if kind not in READABLE:
        return None
    if kind == "msh":
        return _msh_triangles(data)
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
