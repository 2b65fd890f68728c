"""Request and answer schemas of the payload capacity (`service.dynamics.payload_capacity`):
the heaviest point mass a frame can hold within the effort limits, with sizes and units."""

from __future__ import annotations

from pydantic import BaseModel, Field

from service.api.schemas.common import (
    A_DESC,
    BY_NAME,
    V_DESC,
    JointArray,
    JointVector,
    Number,
    QRequest,
    joint_field,
)
from service.api.schemas.payloads import MAX_FRAME_NAME


class PayloadCapacityRequest(QRequest):
    v: JointArray | None = joint_field("Optional, default zero (holding still). " + V_DESC, None)
    a: JointArray | None = joint_field("Optional, default zero. " + A_DESC, None)
    frame: str = Field(
        json_schema_extra={"minLength": 1, "maxLength": MAX_FRAME_NAME},
        description="The frame holding the point mass (a link, joint or fixed frame of the robot).",
    )
    center_of_mass: list[Number] | None = Field(
        None,
        min_length=3,
        max_length=3,
        description="Where the point mass is, in the frame's "
        "axes from its origin, m. Default [0, 0, 0].",
    )
    effort_limits: list[Number] | dict[str, Number | list[Number]] | None = Field(
        None,
        json_schema_extra={"minimum": 0},
        description="nv numbers ≥ 0, N·m or N (or an "
        "object keyed by joint name, every joint named), replacing the model's effort limits; "
        "0 means no limit. A floating root's rows are never limits.",
    )


class CapacityMinimum(BaseModel):
    mass: float | None = Field(
        description="The smallest capacity over the batch, kg; null when nothing limits any state."
    )
    state: int | None = Field(description="The first state (index) that has it.")
    limiting_joint: str | None = Field(description="Its limiting joint.")
    mass_range: list[float | None] | None = Field(
        None,
        description="[lo, hi], kg: the masses that keep every joint within its limit at "
        "every state of the batch (the intersection of the states' ranges; hi null: no upper "
        "end); null when no mass suits every state.",
    )


class PayloadCapacityAnswer(BaseModel):
    mass: float | list[float | None] | None = Field(
        description="The heaviest point mass the frame can hold, kg (one per state for a "
        "batch): the upper end of mass_range, 0 when that range is empty; null when no joint "
        "limits it (a frame fixed to the world, no effort limits)."
    )
    mass_range: list[float | None] | list[list[float | None] | None] | None = Field(
        description="[lo, hi], kg (one per state for a batch): the masses m ≥ 0 with every "
        "joint within its limit, an interval since τ(m) = τ₀ + m τ₁ is affine in m; lo > 0 "
        "when the load is what keeps a joint within its limit (a counterweight); hi null when "
        "nothing limits; null when no mass suits every joint."
    )
    limiting_joint: str | list[str | None] | None = Field(
        description="The joint whose limit sets it (where several are over their limit with "
        "no payload, the one furthest over); null when nothing limits."
    )
    mass_per_joint: list[float | None] | list[list[float | None]] = Field(
        description="nv numbers, kg: the largest mass each velocity coordinate alone allows "
        "(the upper end of its own range); null where it never limits (no effort limit, a "
        "floating root's rows, a joint the mass does not load), 0 where no mass ≥ 0 keeps it "
        "within its limit."
    )
    tau: JointVector = Field(
        description="τ at that mass, nv numbers, N·m or N (τ₀ where nothing limits)." + BY_NAME
    )
    minimum: CapacityMinimum | None = Field(
        None, description="For a batch only: the smallest capacity, where it occurs and its joint."
    )
