"""Request and answer schemas of `POST /v1/robots/{id}/frame-placements`, with units."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, Field

from service.api.schemas.common import QRequest

FrameName = Annotated[str, Field(min_length=1, max_length=1000)]

Positions = list[list[float]] | list[list[list[float]]]
Rotations = list[list[list[float]]] | list[list[list[list[float]]]]


class FramePlacementsRequest(QRequest):
    frames: list[FrameName] | None = Field(
        None,
        max_length=10_000,
        description="Optional names of frames of the model (links, joints, fixed frames; "
        "listed under `frames` of GET /v1/robots/{id}); an unknown name is a 422 "
        "`unknown_frame`. Default: every body frame (one per link), in model order.",
    )


class FramePlacementsAnswer(BaseModel):
    frames: list[str] = Field(
        description="The F frame names the placements are given for, "
        "in order (once, also for a batch)."
    )
    positions: Positions = Field(
        description="World position p of each frame's origin, F×3 in m; (N, F, 3) for a batch."
    )
    rotations: Rotations = Field(
        description="World orientation R of each frame, F×3×3 (the frame's axes as columns in "
        "world coordinates, so a point x of the frame is at p + R x); (N, F, 3, 3) for a "
        "batch."
    )
