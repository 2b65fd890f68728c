"""Request options beyond the joint state: external forces, and answers keyed by joint name.

- `external_forces` on inverse-dynamics and forward-dynamics (`ExternalForce`), by subclassing
  their request models;
- `joint_names` on every dynamics request (`with_joint_names`), which makes the joint-space
  vector answers (τ, a, g, ...) objects keyed by joint name (see `service.joint_names`), and
  `fill`, which lets name-keyed inputs leave joints out.
"""

from __future__ import annotations

import functools
from typing import Annotated, Literal

from pydantic import BaseModel, Field, create_model

from service.api import schemas_dynamics as eom
from service.api.schemas_dynamics import Number, StrictRequest

Wrench = Annotated[list[Number], Field(min_length=6, max_length=6)]
_NamedVector = dict[str, float | list[float]]
JointVector = (list[float] | list[list[float]] | list[list[list[float]]] | _NamedVector
               | list[_NamedVector] | list[list[_NamedVector]])
"""A joint-space answer: an array, or with `"joint_names": true` objects keyed by joint name."""


class ExternalForce(StrictRequest):
    """A wrench the environment applies to the body of `frame`."""

    frame: str = Field(max_length=256, description="A frame of the robot (link, joint or fixed "
                       "frame); the names are under `frames` in GET /v1/robots/{id}.")
    wrench: Wrench | list[Wrench] = Field(
        description="[fx, fy, fz, tx, ty, tz]: force (N) then torque (N·m); or [N][6], one "
        "wrench per state of a batch.")
    reference_frame: Literal["world", "local", "local_world_aligned"] = Field(
        "local_world_aligned", description="local_world_aligned: force and torque about the "
        "frame's origin, world axes; local: about the frame's origin, the frame's axes; world: "
        "about the world origin, world axes (Pinocchio's conventions).")


def _forces_field() -> list[ExternalForce] | None:
    return Field(None, max_length=256, description="Wrenches applied by the environment at "
                 "frames: they add Jᵀ w to the generalized forces (τ = M a + C v + g − Σ Jᵀ w).")


class InverseDynamicsRequest(eom.QVARequest):
    external_forces: list[ExternalForce] | None = _forces_field()


class ForwardDynamicsRequest(eom.QVTauRequest):
    external_forces: list[ExternalForce] | None = _forces_field()


_BY_NAME = " With \"joint_names\": true, an object keyed by joint name (a list for a batch)."


def _named_answer(model: type[BaseModel], *fields: str) -> type[BaseModel]:
    """`model` with `fields` typed as joint-space answers (arrays or name-keyed objects)."""
    changed = {name: (JointVector, Field(description=(model.model_fields[name].description or "")
                                         + _BY_NAME)) for name in fields}
    return create_model(model.__name__, __base__=model, __module__=__name__,
                        __doc__=model.__doc__, **changed)  # type: ignore[call-overload]


@functools.cache
def with_joint_names(model: type[BaseModel]) -> type[BaseModel]:
    """`model` with the `joint_names` option (one subclass per model, so OpenAPI names stay)."""
    return create_model(  # type: ignore[call-overload, no-any-return]
        model.__name__, __base__=model, __module__=model.__module__, __doc__=model.__doc__,
        joint_names=(bool, Field(False, description="Answer joint-space vectors (τ, a, g, "
                                 "C v, h; simulate's q and v) as objects keyed by joint name: "
                                 "a number for a 1-dof joint, a list for others; a list of "
                                 "objects for a batch or trajectory. Matrices stay arrays.")),
        fill=(str | None, Field(None, max_length=256, description="For joint-space inputs "
                                "keyed by joint name: joints left out take their q from this "
                                "configuration — \"neutral\" or one of the robot's "
                                "reference_configurations — and zero v, a and τ. Without it "
                                "every joint must be named (a ROS JointState without its "
                                "gripper is then a 422 listing the missing joints).")))


REQUESTS: dict[str, type[BaseModel]] = {
    "inverse-dynamics": InverseDynamicsRequest,
    "forward-dynamics": ForwardDynamicsRequest,
}

ANSWERS: dict[str, type[BaseModel]] = {
    "gravity": _named_answer(eom.GravityAnswer, "gravity"),
    "coriolis": _named_answer(eom.CoriolisAnswer, "coriolis_forces"),
    "nonlinear-effects": _named_answer(eom.NonlinearEffectsAnswer, "nonlinear_effects"),
    "inverse-dynamics": _named_answer(eom.InverseDynamicsAnswer, "tau"),
    "forward-dynamics": _named_answer(eom.ForwardDynamicsAnswer, "a"),
}
