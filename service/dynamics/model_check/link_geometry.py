"""A link's geometry as one body: its collision elements, else its visual ones, each placed in
the link frame (meshes with their `scale`), added by `geometry.combined`.

A source counts only if every one of its elements gives mass properties (a primitive, or a mesh
that can be read and encloses a volume): half a link's shape would give a wrong volume, centre
and inertia. A mesh that is not closed is replaced by its convex hull and named in
`open_meshes`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from service.dynamics.model_check.geometry import (
    MassProperties,
    closed_mesh,
    combined,
    convex_hull,
    placed,
    primitive,
)
from service.registry.link_descriptions import LinkDescription, ShapeElement
from service.registry.meshes import Triangles

MeshReader = Callable[[str], Triangles | None]
"""Asset key → the mesh's triangles (None: missing or unreadable)."""


@dataclass(frozen=True)
class LinkShape:
    """`source` "collision" or "visual", the unit-density mass properties in the link frame,
    and the asset keys of open meshes replaced by their convex hulls."""

    source: str
    properties: MassProperties
    open_meshes: list[str] = field(default_factory=list)


def _element(
    element: ShapeElement, read: MeshReader, open_meshes: list[str]
) -> MassProperties | None:
    rotation, translation, geometry = element
    if geometry["type"] != "mesh":
        part = primitive(geometry)
    else:
        triangles = read(geometry["asset"])
        if triangles is None:
            return None
        vertices = triangles.vertices * np.asarray(geometry.get("scale", [1, 1, 1]), dtype=float)
        faces = triangles.faces
        if not triangles.closed:
            hull = convex_hull(vertices)
            if hull is None:
                return None
            vertices, faces = hull
            open_meshes.append(geometry["asset"])
        part = closed_mesh(vertices, faces)
    return None if part is None else placed(part, rotation, translation)


def link_geometry(link: LinkDescription, read: MeshReader) -> LinkShape | None:
    """The geometry of `link` (module docstring), None if neither source counts."""
    for source, elements in (("collision", link.collision), ("visual", link.visual)):
        if not elements:
            continue
        open_meshes: list[str] = []
        parts = [_element(e, read, open_meshes) for e in elements]
        if all(p is not None for p in parts):
            whole = combined([p for p in parts if p is not None])
            if whole is not None:
                return LinkShape(source, whole, open_meshes)
    return None
