"""The `external_forces` option of inverse-dynamics and forward-dynamics: wrenches the
environment applies at frames of the robot (`service.dynamics.external_forces`)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field

from service.api.schemas.common import Number, StrictRequest

Wrench = Annotated[list[Number], Field(min_length=6, max_length=6)]


class ExternalForce(StrictRequest):
    """A wrench the environment applies to the body of `frame`."""

    frame: str = Field(
        max_length=256,
        description="A frame of the robot (link, joint or fixed "
        "frame); the names are under `frames` in GET /v1/robots/{id}.",
    )
    wrench: Wrench | list[Wrench] = Field(
        description="[fx, fy, fz, tx, ty, tz]: force (N) then torque (N·m); or [N][6], one "
        "wrench per state of a batch."
    )
    reference_frame: Literal["world", "local", "local_world_aligned"] = Field(
        "local_world_aligned",
        description="local_world_aligned: force and torque about the "
        "frame's origin, world axes; local: about the frame's origin, the frame's axes; world: "
        "about the world origin, world axes (Pinocchio's conventions).",
    )


def forces_field() -> Any:
    """The `external_forces` field of a request model."""
    return Field(
        None,
        max_length=256,
        description="Wrenches applied by the environment at "
        "frames: they add Jᵀ w to the generalized forces (τ = M a + C v + g − Σ Jᵀ w).",
    )
