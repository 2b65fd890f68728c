"""Mass properties of a link's geometry at unit density (1 kg/m³): volume V (m³), centre of
volume c (m) and the inertia about c, J (3×3, m⁵: kg·m² per kg/m³). A mass m spread
uniformly gives the inertia (m / V) J about c.

Primitives in closed form, in their own frame (URDF's: box centred, cylinder and capsule
along z, centred):
- box a × b × c: V = abc, J = V/12 · diag(b² + c², a² + c², a² + b²); a cube of side a and
  mass m has I = m a²/6 about every axis;
- cylinder radius r, length l: V = π r² l, Jxx = Jyy = V (3r² + l²)/12, Jzz = V r²/2;
- sphere radius r: V = 4/3 π r³, J = 2/5 V r² · 1;
- ellipsoid of semi-axes a, b, c (MJCF's): V = 4/3 π abc, J = V/5 · diag(b² + c², a² + c²,
  a² + b²);
- capsule (a cylinder r, l with hemispherical caps): the cylinder plus a sphere's volume
  Vs split in two caps whose centres sit 3r/8 beyond the cylinder's ends:
  Jzz = Vc r²/2 + 2/5 Vs r², Jxx = Vc (l²/12 + r²/4) + Vs (2r²/5 + l²/4 + 3lr/8).
A closed triangle mesh by the divergence theorem: the signed tetrahedra (0, a, b, c) of its
triangles, each of volume v = a · (b × c)/6, centroid (a + b + c)/4 and second moment
∫ x xᵀ = v/20 (a aᵀ + b bᵀ + c cᵀ + s sᵀ), s = a + b + c; J = tr(C) 1 − C with C the total
second moment about c. A mesh with negative total volume (wound inwards) is turned out.
Several elements add (overlaps counted twice), by the parallel-axis theorem:
J = Σ Rᵢ Jᵢ Rᵢᵀ + Vᵢ (|dᵢ|² 1 − dᵢ dᵢᵀ), dᵢ = cᵢ − c.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial import ConvexHull, QhullError


@dataclass(frozen=True)
class MassProperties:
    """Unit-density mass properties: volume (m³), centre (3,) m, inertia (3, 3) m⁵ about it,
    and the bounding box (2, 3) m of the shape, in one frame."""

    volume: float
    center: np.ndarray
    inertia: np.ndarray
    bounds: np.ndarray


def box(size: list[float]) -> MassProperties:
    a, b, c = (float(x) for x in size)
    volume = a * b * c
    inertia = volume / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    half = np.array([a, b, c]) / 2.0
    return MassProperties(volume, np.zeros(3), inertia, np.array([-half, half]))


def cylinder(radius: float, length: float) -> MassProperties:
    r, length = float(radius), float(length)
    volume = math.pi * r * r * length
    side = volume * (3.0 * r * r + length * length) / 12.0
    half = np.array([r, r, length / 2.0])
    return MassProperties(
        volume, np.zeros(3), np.diag([side, side, volume * r * r / 2.0]), np.array([-half, half])
    )


def sphere(radius: float) -> MassProperties:
    r = float(radius)
    volume = 4.0 / 3.0 * math.pi * r**3
    half = np.full(3, r)
    return MassProperties(
        volume, np.zeros(3), np.eye(3) * 0.4 * volume * r * r, np.array([-half, half])
    )


def ellipsoid(radii: list[float]) -> MassProperties:
    a, b, c = (float(x) for x in radii)
    volume = 4.0 / 3.0 * math.pi * a * b * c
    inertia = volume / 5.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    half = np.array([a, b, c])
    return MassProperties(volume, np.zeros(3), inertia, np.array([-half, half]))


def capsule(radius: float, length: float) -> MassProperties:
    r, length = float(radius), float(length)
    vc, vs = math.pi * r * r * length, 4.0 / 3.0 * math.pi * r**3
    axial = vc * r * r / 2.0 + 0.4 * vs * r * r
    side = vc * (length**2 / 12.0 + r * r / 4.0) + vs * (
        0.4 * r * r + length**2 / 4.0 + 3.0 * length * r / 8.0
    )
    half = np.array([r, r, length / 2.0 + r])
    return MassProperties(
        vc + vs, np.zeros(3), np.diag([side, side, axial]), np.array([-half, half])
    )


def closed_mesh(vertices: np.ndarray, faces: np.ndarray) -> MassProperties | None:
    """The mass properties of the solid a closed triangle mesh bounds (vertices (n, 3) m, faces
    (m, 3)), None if it encloses no volume."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    v = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    volume = float(v.sum())
    if volume < 0.0:
        v, volume = -v, -volume
    if not volume > 0.0:
        return None
    s = a + b + c
    center = (v[:, None] * s).sum(axis=0) / 4.0 / volume
    second = np.einsum("i,ij,ik->jk", v, a, a)
    second += np.einsum("i,ij,ik->jk", v, b, b)
    second += np.einsum("i,ij,ik->jk", v, c, c)
    second += np.einsum("i,ij,ik->jk", v, s, s)
    second = second / 20.0 - volume * np.outer(center, center)  # about the centre
    inertia = np.trace(second) * np.eye(3) - second
    bounds = np.array([vertices.min(axis=0), vertices.max(axis=0)])
    return MassProperties(volume, center, (inertia + inertia.T) / 2.0, bounds)


def convex_hull(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(vertices, faces) of the convex hull of points (n, 3), faces wound outwards; None if
    the points span no volume."""
    try:
        hull = ConvexHull(vertices)
    except (QhullError, ValueError):
        return None
    faces = hull.simplices.copy()
    inside = vertices[hull.vertices].mean(axis=0)
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), a - inside) < 0.0
    faces[inward] = faces[inward][:, ::-1]
    return vertices, faces


def primitive(geometry: dict[str, Any]) -> MassProperties | None:
    """A box, cylinder, sphere, capsule or ellipsoid of the API's geometry form; None for
    anything else."""
    kind = geometry["type"]
    if kind == "box":
        return box(geometry["size"])
    if kind == "cylinder":
        return cylinder(geometry["radius"], geometry["length"])
    if kind == "sphere":
        return sphere(geometry["radius"])
    if kind == "capsule":
        return capsule(geometry["radius"], geometry["length"])
    if kind == "ellipsoid":
        return ellipsoid(geometry["radii"])
    return None


def placed(part: MassProperties, rotation: np.ndarray, translation: np.ndarray) -> MassProperties:
    """`part` expressed in a frame where its own frame has `rotation` and `translation`."""
    corners = np.array(
        [
            [part.bounds[i, 0], part.bounds[j, 1], part.bounds[k, 2]]
            for i in (0, 1)
            for j in (0, 1)
            for k in (0, 1)
        ]
    )
    moved = corners @ rotation.T + translation
    return MassProperties(
        part.volume,
        rotation @ part.center + translation,
        rotation @ part.inertia @ rotation.T,
        np.array([moved.min(axis=0), moved.max(axis=0)]),
    )


def combined(parts: list[MassProperties]) -> MassProperties | None:
    """Several parts in one frame as one body (overlaps counted twice); None without volume."""
    volume = sum(p.volume for p in parts)
    if not volume > 0.0:
        return None
    center = sum((p.volume * p.center for p in parts), np.zeros(3)) / volume
    inertia = np.zeros((3, 3))
    for p in parts:
        d = p.center - center
        inertia += p.inertia + p.volume * (d @ d * np.eye(3) - np.outer(d, d))
    bounds = np.array(
        [np.min([p.bounds[0] for p in parts], axis=0), np.max([p.bounds[1] for p in parts], axis=0)]
    )
    return MassProperties(volume, center, inertia, bounds)
