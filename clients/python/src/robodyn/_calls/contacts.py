"""Request builders of the contact routes: constrained forward dynamics, contact-consistent
inverse dynamics and impacts (simulation with contacts is `dynamics.simulate`). (The clients'
docstrings describe them.)"""

from __future__ import annotations

from robodyn._calls.request import request
from robodyn.arrays import ArrayLike
from robodyn.contacts import (
    ContactDynamics,
    ContactInverseDynamics,
    ContactsLike,
    ImpulseDynamics,
    contact_options,
    nonnegative,
)
from robodyn.core import Call
from robodyn.payloads import PayloadsLike


def contact_dynamics(
    robot_id: str,
    q: ArrayLike,
    v: ArrayLike,
    tau: ArrayLike,
    contacts: ContactsLike,
    *,
    damping: float = 0.0,
    payloads: PayloadsLike | None = None,
) -> Call[ContactDynamics]:
    return request(
        robot_id,
        "contact-dynamics",
        ContactDynamics.from_json,
        contact_options(contacts, damping),
        payloads=payloads,
        q=q,
        v=v,
        tau=tau,
    )


def contact_inverse_dynamics(
    robot_id: str,
    q: ArrayLike,
    v: ArrayLike,
    a: ArrayLike,
    contacts: ContactsLike,
    *,
    damping: float = 0.0,
    payloads: PayloadsLike | None = None,
) -> Call[ContactInverseDynamics]:
    return request(
        robot_id,
        "contact-inverse-dynamics",
        ContactInverseDynamics.from_json,
        contact_options(contacts, damping),
        payloads=payloads,
        q=q,
        v=v,
        a=a,
    )


def impulse_dynamics(
    robot_id: str,
    q: ArrayLike,
    v: ArrayLike,
    contacts: ContactsLike,
    *,
    restitution: float = 0.0,
    damping: float = 0.0,
    payloads: PayloadsLike | None = None,
) -> Call[ImpulseDynamics]:
    options = contact_options(contacts, damping)
    options["restitution"] = nonnegative("restitution", restitution, upper=1.0)
    return request(
        robot_id,
        "impulse-dynamics",
        ImpulseDynamics.from_json,
        options,
        payloads=payloads,
        q=q,
        v=v,
    )
