"""Answer schema of `GET /v1/robots/{id}/visuals`: a robot's visual elements, with units."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field


class Placement(BaseModel):
    translation: list[float] = Field(description="[x, y, z] in m, in the link's body frame.")
    rotation: list[list[float]] = Field(
        description="3×3 rotation matrix (row-major): the "
        "visual's axes as columns in the body frame."
    )


class MeshGeometry(BaseModel):
    type: Literal["mesh"]
    asset: str = Field(
        description="Path of the mesh file, relative with `/` separators; "
        "fetch it from GET /v1/robots/{id}/assets/{asset}."
    )
    scale: list[float] = Field(
        description="Scale factors [sx, sy, sz] of the mesh's "
        "coordinates (the mesh file's units are the description's)."
    )


class BoxGeometry(BaseModel):
    type: Literal["box"]
    size: list[float] = Field(description="Full extents [x, y, z] in m, centred on the origin.")


class SphereGeometry(BaseModel):
    type: Literal["sphere"]
    radius: float = Field(description="m")


class CylinderGeometry(BaseModel):
    type: Literal["cylinder", "capsule"]
    radius: float = Field(description="m")
    length: float = Field(
        description="m, along the visual's z axis, centred on the origin "
        "(a capsule's length excludes its end caps)."
    )


Geometry = MeshGeometry | BoxGeometry | SphereGeometry | CylinderGeometry


class Visual(BaseModel):
    name: str = Field(
        description="`<link>_<index>`: the link's name and the visual's index "
        "among that link's visuals (as Pinocchio names its geometries; unique)."
    )
    frame: str = Field(
        description="The body frame of the visual's link, as in `frames` of "
        "GET /v1/robots/{id} and in frame-placements."
    )
    placement: Placement = Field(description="The visual's placement relative to `frame`.")
    geometry: Geometry = Field(discriminator="type")
    color: list[float] | None = Field(
        description="RGBA in 0–1, or null where the "
        "description gives none (a mesh may carry its own)."
    )


class Visuals(BaseModel):
    visuals: list[Visual] = Field(
        description="Every visual element of the description, in its order; empty when it has none."
    )
