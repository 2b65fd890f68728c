"""The visual elements of a compiled MJCF (`mujoco.MjModel`), shaped as `GET .../visuals` answers.

Every geom MuJoCo draws by default (groups 0–2, not fully transparent), except planes, height
fields, ellipsoids and SDFs: `frame` is its body's frame name in the Pinocchio model (`universe`
for the world body), `placement` its pose in that frame, `geometry` a primitive with URDF's full
extents (box `size` = 2 × MuJoCo's half sizes, cylinder and capsule `length` = 2 × half length) or
a mesh by its asset key and scale, `color` its material's or its own RGBA. MuJoCo moves a mesh's
vertices to its inertial frame (`mesh_pos`, `mesh_quat`) and the geom with them; the placement
given is that of the mesh file's own frame, geom pose · (mesh_pos, mesh_quat)⁻¹.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from service.registry.assets import normalize_key
from service.registry.mjcf_build import se3

SPHERE, CAPSULE, CYLINDER, BOX, MESH = 2, 3, 5, 6, 7  # mujoco.mjtGeom
DRAWN_GROUPS = 3  # MuJoCo's viewer shows groups 0, 1 and 2 by default


def _path(mj: Any, adr: int) -> str | None:
    if adr < 0:
        return None
    raw = bytes(mj.paths[adr:])
    return raw[: raw.index(b"\0")].decode("utf-8", "replace") if b"\0" in raw else None


def _geometry(mj: Any, g: int) -> tuple[dict[str, Any] | None, Any]:
    """(geometry, the placement correction of a mesh) of geom `g`, or (None, _) if not drawn."""
    kind, size = int(mj.geom_type[g]), [float(x) for x in mj.geom_size[g]]
    if kind == SPHERE:
        return {"type": "sphere", "radius": size[0]}, None
    if kind in (CAPSULE, CYLINDER):
        return {
            "type": "capsule" if kind == CAPSULE else "cylinder",
            "radius": size[0],
            "length": 2 * size[1],
        }, None
    if kind == BOX:
        return {"type": "box", "size": [2 * s for s in size]}, None
    if kind == MESH:
        mesh = int(mj.geom_dataid[g])
        path = _path(mj, int(mj.mesh_pathadr[mesh]))
        if path is None:  # vertices given in the XML: no file to serve
            return None, None
        geometry = {
            "type": "mesh",
            "asset": normalize_key(path),
            "scale": [float(x) for x in mj.mesh_scale[mesh]],
        }
        return geometry, se3(mj.mesh_quat[mesh], mj.mesh_pos[mesh]).inverse()
    return None, None


def mjcf_visuals(mj: Any, body_frames: list[str]) -> list[dict[str, Any]]:
    """The visual entries of `mj`; `body_frames[b]` names body b's frame."""
    out = []
    for g in range(mj.ngeom):
        if mj.geom_group[g] >= DRAWN_GROUPS:
            continue
        material = int(mj.geom_matid[g])
        rgba = mj.mat_rgba[material] if material >= 0 else mj.geom_rgba[g]
        if rgba[3] <= 0:
            continue
        geometry, correction = _geometry(mj, g)
        if geometry is None:
            continue
        placement = se3(mj.geom_quat[g], mj.geom_pos[g])
        if correction is not None:
            placement = placement * correction
        out.append(
            {
                "name": mj.geom(g).name or f"geom{g}",
                "frame": body_frames[int(mj.geom_bodyid[g])],
                "placement": {
                    "translation": [float(x) for x in placement.translation],
                    "rotation": np.asarray(placement.rotation).tolist(),
                },
                "geometry": geometry,
                "color": [float(c) for c in rgba],
            }
        )
    return out
