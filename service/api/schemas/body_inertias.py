"""Answer schema of GET /v1/robots/{id}/inertias: every body's inertial parameters."""

from __future__ import annotations

from pydantic import BaseModel, Field


class BodyInertia(BaseModel):
    name: str = Field(description="The link the joint moves (the body's first link).")
    joint: str = Field(
        description="The joint that moves this body; every vector and matrix "
        "below is in this joint's frame (at the joint origin)."
    )
    links: list[str] = Field(
        description="Every link of the body: the joint's child link and "
        "the links fixed to it, merged into one rigid body."
    )
    mass: float = Field(description="m, kg.")
    center_of_mass: list[float] = Field(description="c, [x, y, z] in m, in the joint frame.")
    inertia_at_center_of_mass: list[list[float]] = Field(
        description="I_c, 3×3 symmetric, kg·m²: rotational inertia about the centre of mass, "
        "in the joint frame's axes."
    )
    inertia_at_joint: list[list[float]] = Field(
        description="I_o = I_c + m (‖c‖² 1 − c cᵀ), 3×3, kg·m²: about the joint origin "
        "(parallel-axis theorem)."
    )
    principal_moments: list[float] = Field(
        description="Eigenvalues of I_c in ascending order, kg·m²."
    )
    principal_axes: list[list[float]] = Field(
        description="R, 3×3 rotation (det +1) whose columns are the principal axes in the "
        "joint frame, in the order of `principal_moments`: I_c = R diag(moments) Rᵀ."
    )


class Inertias(BaseModel):
    total_mass: float = Field(
        description="Sum of the bodies' masses, kg (RobotInfo's "
        "total_mass). Links fixed to the world do not move and are not "
        "listed."
    )
    bodies: list[BodyInertia] = Field(
        description="One body per joint, in model order (the order of RobotInfo's joints)."
    )
