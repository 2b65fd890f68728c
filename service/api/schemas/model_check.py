"""Schemas of the model check (`GET /v1/robots/{id}/model-check`) and of the inertia repairs
a variant asks for (`inertias` of `POST /v1/robots/{id}/variants`)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, Field

from service.api.schemas.common import StrictRequest

MAX_REPAIRED_LINKS = 1000
MAX_LINK_NAME = 256


class Suggestion(BaseModel):
    attribute: Literal["ixx", "ixy", "ixz", "iyy", "iyz", "izz"] = Field(
        description="The `<inertia>` attribute, as written in the description."
    )
    value: float = Field(
        description="The written value times the power of ten (10⁻⁶ … 10³) that removes the "
        "error, kg·m²."
    )


class ModelCheckFinding(BaseModel):
    code: Literal[
        "negative_principal_moment",
        "triangle_inequality",
        "inertia_without_mass",
        "point_mass_with_geometry",
        "massless_with_geometry",
        "implausible_density",
        "center_of_mass_outside_geometry",
        "inertia_geometry_mismatch",
        "mirror_asymmetry",
        "open_mesh",
    ]
    severity: Literal["error", "warning"] = Field(
        description="error: no rigid body has it; warning: possible, rarely meant."
    )
    link: str = Field(description="The link (for mirror_asymmetry, the first of the twins).")
    message: str = Field(description="What is wrong, with the numbers.")
    suggestion: Suggestion | None = Field(
        description="For an error that exactly one inertia attribute off by a power of ten "
        "explains: that attribute and its corrected value; else null."
    )


class LinkGeometry(BaseModel):
    source: Literal["collision", "visual"] = Field(
        description="The link's collision elements, else its visual ones."
    )
    volume: float = Field(description="m³ (several elements added, overlaps counted twice).")
    density: float = Field(description="The link's mass ÷ volume, kg/m³.")
    center_of_mass: list[float] = Field(description="Centre of volume, [3] m, link frame.")
    inertia: list[list[float]] | None = Field(
        description="3×3 kg·m² about the geometry's centre, link axes, the declared mass "
        "spread uniformly; null for a massless link."
    )


class LinkFacts(BaseModel):
    name: str
    mass: float = Field(description="kg, as declared.")
    center_of_mass: list[float] = Field(description="[3] m, link frame, as declared.")
    principal_moments: list[float] = Field(
        description="[3] kg·m², about the centre of mass, ascending (eigenvalues of the "
        "declared inertia)."
    )
    inertia: list[list[float]] = Field(
        description="3×3 kg·m², the declared inertia about the centre of mass, link axes."
    )
    geometry: LinkGeometry | None = Field(
        description="The mass properties of the link's shape; null without a shape whose "
        "volume is known."
    )


class ModelCheck(BaseModel):
    findings: list[ModelCheckFinding] = Field(
        description="Errors and warnings, link by link in the description's order, then "
        "the left/right twins'."
    )
    links: list[LinkFacts] = Field(description="One per link with mass, inertia or geometry.")


class InertiaRepair(StrictRequest):
    """Link inertials replaced in a variant (mass kept)."""

    links: (
        Annotated[
            list[Annotated[str, Field(max_length=MAX_LINK_NAME)]],
            Field(min_length=1, max_length=MAX_REPAIRED_LINKS),
        ]
        | Literal["errors", "all"]
    ) = Field(
        description='Link names, "errors" (every link with an error) or "all" (every link '
        "with mass, inertia or geometry).",
    )
    from_: Literal["geometry", "nearest_valid"] = Field(
        alias="from",
        description="geometry: centre of mass and inertia of the link's shape with its mass "
        "(a link without geometry is a 422 naming it); nearest_valid: centre of mass and "
        "principal axes kept, principal moments replaced by the closest valid ones (least "
        "squares, λᵢ ≥ 0, λᵢ + λⱼ ≥ λₖ).",
    )
