"""Schemas of payloads (the `payloads` option of every computing route) and variants
(`POST /v1/robots/{id}/variants`).

The values of a payload (mass > 0, the inertia's symmetry, positive semidefiniteness and
triangle inequality, the frame) are checked once, by the physics
(`service.dynamics.payloads`), whose errors name the payload by its index; these models declare
the JSON shape and show the same bounds in the OpenAPI document. Only the number of payloads is
also enforced while parsing (`maxItems`).
"""

from __future__ import annotations

from typing import Any

from pydantic import Field

from service.api.schemas.common import (
    Number,
    RoutedRequest,
    StrictRequest,
)
from service.api.schemas.model_check import InertiaRepair
from service.api.schemas.robots import LOCKED_DESC, LockedJointValue
from service.dynamics.payloads import MAX_PAYLOADS

MAX_FRAME_NAME = 256


class Payload(StrictRequest):
    """A rigid body held by a frame, added to the body that carries the frame."""

    frame: str = Field(
        json_schema_extra={"minLength": 1, "maxLength": MAX_FRAME_NAME},
        description="A frame of the robot (link, joint or fixed frame; the "
        "`frames` of GET /v1/robots/{id}). An unknown name is a 422 "
        "`unknown_frame`.",
    )
    mass: Number = Field(json_schema_extra={"exclusiveMinimum": 0}, description="kg, > 0.")
    center_of_mass: list[Number] | None = Field(
        None,
        json_schema_extra={"minItems": 3, "maxItems": 3},
        description="The payload's "
        "centre of mass in the frame's axes, from the frame's origin, m. Default [0, 0, 0].",
    )
    inertia: list[list[Number]] | None = Field(
        None,
        json_schema_extra={"minItems": 3, "maxItems": 3},
        description="3×3 rotational "
        "inertia about the payload's own centre of mass, in the frame's axes, kg·m²: symmetric, "
        "positive semidefinite, principal moments with λ₁ + λ₂ ≥ λ₃. Default zero (a point "
        "mass).",
    )


def payloads_field() -> Any:
    return Field(
        None,
        max_length=MAX_PAYLOADS,
        description=(
            f"Rigid bodies the robot holds (at most {MAX_PAYLOADS}), each added to the body that "
            "carries its frame "
            "(inertias[frame.parentJoint] += frame.placement · Inertia(m, c, I)): "
            "every answer is that of the robot carrying them. A bad payload is a 422 naming it "
            "(`validation_error`, with `payload`: its index, and `field`; or `unknown_frame`)."
        ),
    )


class VariantRequest(RoutedRequest):
    payloads: list[Payload] | None = Field(
        None,
        max_length=MAX_PAYLOADS,
        description=(
            f"Rigid bodies the variant carries (at most {MAX_PAYLOADS}), added to the bodies "
            "that carry their frames before any joint is locked."
        ),
    )
    locked_joints: dict[str, LockedJointValue] | None = Field(
        None, max_length=1000, description=LOCKED_DESC
    )
    inertias: InertiaRepair | None = Field(
        None,
        description="Link inertials repaired first (GET .../model-check says which are "
        "wrong): every route of the variant computes with them; `modifications.inertias` "
        "lists each repair.",
    )
    name: str | None = Field(
        None,
        max_length=200,
        description="Optional label; defaults to "
        "the parent's name + ' (variant)'. Not part of the id.",
    )
