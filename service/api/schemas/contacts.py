"""Request and answer schemas of the contact endpoints: contact-dynamics,
contact-inverse-dynamics and impulse-dynamics (`service.dynamics.contacts`); `Contact` and the
damping field are also simulate's (`service.api.schemas.simulation`). Option defaults equal the
keyword defaults of the computing functions.

The values of a contact set (at least one contact, its type, its frame name, `damping`,
`restitution`) are checked once, by the physics (`service.dynamics.contacts.model`,
`contacts.solve`); these models declare the JSON shape and show the same bounds in the
OpenAPI document, read from the same constants. Only the number of contacts is also enforced
while parsing (`maxItems`), so that an oversized list is refused before its items are built.
"""

from __future__ import annotations

from pydantic import BaseModel, Field

from service.api.schemas.common import (
    JointVector,
    QVARequest,
    QVRequest,
    QVTauRequest,
    StrictRequest,
)
from service.dynamics.contacts.model import KINDS, MAX_CONTACTS, MAX_FRAME_NAME
from service.dynamics.contacts.solve import MAX_DAMPING

FORCES_LAYOUT = (
    "expressed at each contact frame's origin with the world's axes (local_world_aligned): 3 "
    "numbers per `point` contact, 6 per `6d` contact (force first, then torque), "
    "concatenated in the order of `contacts` (m numbers in all)"
)


class Contact(StrictRequest):
    """A rigid contact at a frame of the model."""

    frame: str = Field(
        json_schema_extra={"minLength": 1, "maxLength": MAX_FRAME_NAME},
        description=(
            "A frame of the robot (link, joint or fixed frame); the names are under `frames` and "
            "suggested feet under `contact_frames` in GET /v1/robots/{id}. An unknown name is a "
            "422 `unknown_frame`; a frame attached to the world is a 422 "
            "`singular_configuration`."
        ),
    )
    type: str = Field(
        "point",
        json_schema_extra={"enum": list(KINDS)},
        description=(
            "`point`: the frame's origin does not move (its classical linear acceleration is "
            "zero), 3 force components; `6d`: the frame neither moves nor turns (its spatial "
            "acceleration in its LOCAL frame is zero), 3 force and 3 torque components."
        ),
    )


def _contacts_field() -> list[Contact]:
    field: list[Contact] = Field(
        max_length=MAX_CONTACTS,
        json_schema_extra={"minItems": 1},
        description=(
            "The contact set, the same for every state of a batch. Contact forces are "
            + FORCES_LAYOUT
            + "."
        ),
    )
    return field


def damping_field() -> float:
    return Field(
        0.0,
        allow_inf_nan=False,
        json_schema_extra={"minimum": 0.0, "maximum": MAX_DAMPING},
        description=(
            "Damping μ in [0, 1] (1/kg, the units of Jc M⁻¹ Jcᵀ) for a rank-deficient contact "
            "Jacobian Jc (e.g. two contacts at one point). With 0 (default) a contact set whose "
            "Delassus matrix Jc M⁻¹ Jcᵀ has a pivot at most 1e-8 times its largest is a 422 "
            "`singular_configuration`; with μ > 0 the regularized (proximal) solution is iterated "
            "until the constraints hold to 1e-9 (1 + the size of their right-hand side), or the "
            "answer is a 422 `singular_configuration` giving the residual reached: see "
            "docs/contacts.md."
        ),
    )


class ContactDynamicsRequest(QVTauRequest):
    contacts: list[Contact] = _contacts_field()
    damping: float = damping_field()


class ContactInverseDynamicsRequest(QVARequest):
    contacts: list[Contact] = _contacts_field()
    damping: float = damping_field()


class ImpulseDynamicsRequest(QVRequest):
    contacts: list[Contact] = _contacts_field()
    restitution: float = Field(
        0.0,
        allow_inf_nan=False,
        json_schema_extra={"minimum": 0.0, "maximum": 1.0},
        description=(
            "Coefficient of restitution e in [0, 1]: Jc v⁺ = −e Jc v⁻ (0: the contacts stop, "
            "perfectly inelastic; 1: they bounce back, elastic)."
        ),
    )
    damping: float = damping_field()


class ContactDynamicsAnswer(BaseModel):
    a: JointVector = Field(
        description="Joint acceleration a, length nv (rad/s², m/s²), "
        "solving M a + h = τ + Jcᵀ λ with Jc a + γ = 0; (N, nv) for a batch."
    )
    contact_forces: list[float] | list[list[float]] = Field(
        description="Contact forces λ, N and N·m, " + FORCES_LAYOUT + "; (N, m) for a batch."
    )


class ContactInverseDynamicsAnswer(BaseModel):
    tau: JointVector = Field(
        description=(
            "Joint torques τ, length nv (N·m, N): zero on a floating base's root rows (6 for a "
            "free-flyer, 3 for a planar root); τ = M a + h − Jcᵀ λ on the other rows. For a "
            "fixed-base robot τ = M a + h and λ = 0."
        )
    )
    contact_forces: list[float] | list[list[float]] = Field(
        description=(
            "Contact forces λ, N and N·m, " + FORCES_LAYOUT + ": the minimum-Euclidean-norm "
            "solution of the root rows (M a + h)_root = (Jcᵀ λ)_root (no friction cone, no "
            "unilaterality); (N, m) for a batch."
        )
    )
    residual: float | list[float] = Field(
        description=(
            "2-norm of (Jcᵀ λ − M a − h) on the root rows: the part of the motion no contact "
            "force can produce (0 when the contacts can hold the motion); N and N·m mixed."
        )
    )


class ImpulseDynamicsAnswer(BaseModel):
    v: JointVector = Field(
        description="Velocity just after the impact, length nv: "
        "M (v⁺ − v⁻) = Jcᵀ Λ with Jc v⁺ = −e Jc v⁻; (N, nv) for a batch."
    )
    contact_impulses: list[float] | list[list[float]] = Field(
        description="Contact impulses Λ, N·s and N·m·s, laid out like contact forces: "
        + FORCES_LAYOUT
        + "; (N, m) for a batch."
    )
