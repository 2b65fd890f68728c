"""Request and answer schemas of a frame's Jacobian (`service.dynamics.frames`): the frame and
reference-frame fields (also those of operational-space), J and J̇ with sizes and units.

Option defaults equal the keyword defaults of `service.dynamics.frames.jacobian`.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from service.api.schemas.common import Matrix, OptionalVRequest

FRAME_DESC = (
    "Name of a frame of the model: a link, a joint or a fixed frame. The valid names "
    "are listed under `frames` of GET /v1/robots/{id}; an unknown name is a 422 "
    "`unknown_frame`."
)
REFERENCE_DESC = (
    "The coordinates of 6-vectors [linear; angular] (linear first): `local_world_aligned` "
    "(default) the world's axes at the frame's origin, linear part = velocity of the frame's "
    "origin in world coordinates; `local` the frame's own axes; `world` the world frame, linear "
    "part = velocity of the body point at the world origin (spatial velocity). As in Pinocchio."
)

ReferenceFrameField = Literal["world", "local", "local_world_aligned"]


class JacobianRequest(OptionalVRequest):
    frame: str = Field(min_length=1, max_length=1000, description=FRAME_DESC)
    reference_frame: ReferenceFrameField = Field("local_world_aligned", description=REFERENCE_DESC)


class JacobianAnswer(BaseModel):
    jacobian: Matrix = Field(
        description="Frame Jacobian J(q), 6×nv: rows [vx, vy, vz, ωx, ωy, ωz] (m/s and "
        "rad/s per unit of v) in `reference_frame`; the frame's velocity is J v."
    )
    jacobian_time_variation: Matrix | None = Field(
        None,
        description="Only with v: J̇(q, v) = dJ/dt, 6×nv; the frame's acceleration in "
        "`reference_frame` is J a + J̇ v.",
    )
