"""What a compiled MJCF (`mujoco.MjModel`) says about each body's mass and shape, as the links
of the model check (`LinkDescription`), read where the MJCF is compiled for the check: a child
process with a build's limits, never the serving process.

One link per body but the world body, named after its body frame in the Pinocchio model
(`mjcf_build`), in the body frame, as the inertias are built: mass `body_mass`, centre of mass
`body_ipos`, inertia R diag(`body_inertia`) Rᵀ with R the rotation of `body_iquat` (kg, m,
kg·m² about the centre of mass). Its geoms, each placed by `geom_pos`, `geom_quat` in the body
frame: collision ones (`contype | conaffinity` nonzero), else visual ones (every other geom).
MuJoCo's sizes are half sizes: a box of half sizes (a, b, c) is `size` [2a, 2b, 2c], a capsule
or cylinder of half length h has `length` 2h, an ellipsoid its three semi-axes `radii`. A mesh
geom is the compiled model's own triangles (`mesh_vert`, `mesh_face`: scaled, in the mesh's
frame MuJoCo moved them to, where the geom's pose places them), so every mesh format MuJoCo
reads is read. Planes, height fields and SDFs have no volume: a body with one has no geometry
from that source (`{"type": "unsupported"}`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from service.registry.link_descriptions import LinkDescription, ShapeElement
from service.registry.meshes import Triangles, closed_triangles
from service.registry.mjcf_build import se3

SPHERE, CAPSULE, ELLIPSOID, CYLINDER, BOX, MESH = 2, 3, 4, 5, 6, 7  # mujoco.mjtGeom


def _mesh_key(mj: Any, mesh: int) -> str:
    return f"mjcf-mesh:{mj.mesh(mesh).name or mesh}"


def _geometry(mj: Any, g: int) -> dict[str, Any]:
    kind, size = int(mj.geom_type[g]), [float(x) for x in mj.geom_size[g]]
    if kind == SPHERE:
        return {"type": "sphere", "radius": size[0]}
    if kind in (CAPSULE, CYLINDER):
        return {
            "type": "capsule" if kind == CAPSULE else "cylinder",
            "radius": size[0],
            "length": 2.0 * size[1],
        }
    if kind == ELLIPSOID:
        return {"type": "ellipsoid", "radii": size}
    if kind == BOX:
        return {"type": "box", "size": [2.0 * s for s in size]}
    if kind == MESH:
        return {"type": "mesh", "asset": _mesh_key(mj, int(mj.geom_dataid[g])), "scale": [1, 1, 1]}
    return {"type": "unsupported"}


def mjcf_meshes(mj: Any) -> dict[str, Triangles | None]:
    """Every mesh of `mj` by the key its geoms' geometry names: its compiled vertices (m) and
    triangles (None: a mesh without a triangle)."""
    out = {}
    for m in range(mj.nmesh):
        first, count = int(mj.mesh_vertadr[m]), int(mj.mesh_vertnum[m])
        face, faces = int(mj.mesh_faceadr[m]), int(mj.mesh_facenum[m])
        out[_mesh_key(mj, m)] = closed_triangles(
            np.asarray(mj.mesh_vert[first : first + count], dtype=float),
            np.asarray(mj.mesh_face[face : face + faces], dtype=np.int64),
        )
    return out


def _moves(mj: Any, b: int, root_joint: str) -> bool:
    while b > 0:
        if int(mj.body_jntnum[b]) > 0:
            return True
        b = int(mj.body_parentid[b])
    return root_joint != "fixed"


def mjcf_links(mj: Any, body_frames: list[str], root_joint: str) -> list[LinkDescription]:
    """The links of compiled model `mj` (module docstring); `body_frames[b]` names body b's
    frame, `root_joint` the joint robodyn mounts the model on ("fixed": none)."""
    collision: list[list[ShapeElement]] = [[] for _ in range(mj.nbody)]
    visual: list[list[ShapeElement]] = [[] for _ in range(mj.nbody)]
    for g in range(mj.ngeom):
        placement = se3(mj.geom_quat[g], mj.geom_pos[g])
        element = (
            np.asarray(placement.rotation, dtype=float),
            np.asarray(placement.translation, dtype=float),
            _geometry(mj, g),
        )
        touches = int(mj.geom_contype[g]) | int(mj.geom_conaffinity[g])
        (collision if touches else visual)[int(mj.geom_bodyid[g])].append(element)
    out = []
    for b in range(1, mj.nbody):
        rotation = np.asarray(se3(mj.body_iquat[b], np.zeros(3)).rotation, dtype=float)
        out.append(
            LinkDescription(
                name=body_frames[b],
                mass=float(mj.body_mass[b]),
                center_of_mass=np.asarray(mj.body_ipos[b], dtype=float),
                inertia=rotation
                @ np.diag(np.asarray(mj.body_inertia[b], dtype=float))
                @ rotation.T,
                attributes=None,
                moves=_moves(mj, b, root_joint),
                collision=collision[b],
                visual=visual[b],
            )
        )
    return out
