"""Contacts in the client: the `Contact` type, the local check of a `contacts` argument, and
the named results of the contact endpoints (contact-dynamics, contact-inverse-dynamics,
impulse-dynamics, simulate with contacts).

Contact forces are expressed at each contact frame's origin with the world's axes: 3 numbers
per "point" contact (N), 6 per "6d" contact (force N, then torque N·m), concatenated in the
order of the contacts (m numbers in all).
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping, Sequence
from typing import Any, Literal, NamedTuple, TypedDict

import numpy as np

from robodyn.errors import InputError
from robodyn.results import read, trajectory_arrays

ContactType = Literal["point", "6d"]
CONTACT_TYPES = ("point", "6d")


class Contact(TypedDict, total=False):
    """A rigid contact: `{"frame": "FL_FOOT", "type": "point"}` ("point" by default; "6d"
    for a flat sole or a grasp). `RobotInfo.contact_frames` lists a robot's feet as such."""

    frame: str
    type: ContactType


ContactsLike = Sequence[Contact | Mapping[str, Any] | str]
"""A list of contacts: mappings {"frame", "type"}, or bare frame names (point contacts)."""


def contacts_body(contacts: ContactsLike) -> list[dict[str, str]]:
    """The `contacts` body member, checked locally (frame names are checked by the server)."""
    if isinstance(contacts, str | Mapping) or not isinstance(contacts, Sequence) or not contacts:
        raise InputError(
            "contacts must be a non-empty list of {'frame': name, 'type': "
            "'point' | '6d'} (or of frame names)"
        )
    out = []
    for k, contact in enumerate(contacts):
        if isinstance(contact, str):
            contact = {"frame": contact, "type": "point"}
        if not isinstance(contact, Mapping) or not isinstance(contact.get("frame"), str):
            raise InputError(f"contacts[{k}] must be a mapping with a 'frame' name (str)")
        unknown = set(contact) - {"frame", "type"}
        if unknown:
            raise InputError(
                f"contacts[{k}] has unknown keys {sorted(unknown)}; a contact "
                "has 'frame' and 'type'"
            )
        kind = contact.get("type", "point")
        if kind not in CONTACT_TYPES:
            raise InputError(f"contacts[{k}]['type'] must be 'point' or '6d', not {kind!r}")
        out.append({"frame": contact["frame"], "type": kind})
    return out


def nonnegative(name: str, value: Any, upper: float | None = None) -> float:
    """A finite number ≥ 0 (and ≤ upper), as float; else InputError."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{name} must be a number, not {type(value).__name__}")
    number = float(value)
    if not np.isfinite(number) or number < 0 or (upper is not None and number > upper):
        bound = f" and ≤ {upper:g}" if upper is not None else ""
        raise InputError(f"{name} must be a finite number ≥ 0{bound}, not {value!r}")
    return number


def contact_options(contacts: ContactsLike, damping: float) -> dict[str, Any]:
    """The `contacts` and `damping` body members of a contact route, checked."""
    options: dict[str, Any] = {"contacts": contacts_body(contacts)}
    if nonnegative("damping", damping):
        options["damping"] = float(damping)
    return options


class ContactDynamics(NamedTuple):
    """Constrained forward dynamics: `a` (nv,), rad/s² and m/s², and `contact_forces` λ (m,),
    N and N·m, with M a + h = τ + Jcᵀ λ and Jc a + γ = 0; a leading axis N for a batch."""

    a: np.ndarray
    contact_forces: np.ndarray

    @classmethod
    def from_json(cls, body: Mapping[str, Any], batched: bool, rows: int | None) -> ContactDynamics:
        return cls(
            read(body, "a", 1, batched, rows), read(body, "contact_forces", 1, batched, rows)
        )


class ContactInverseDynamics(NamedTuple):
    """Contact-consistent inverse dynamics: `tau` (nv,), zero on a floating root's rows,
    `contact_forces` λ (m,), the minimum-norm forces that hold the root's motion, and
    `residual` (float; (N,) for a batch), the 2-norm of what no contact force can produce on
    the root rows (0 when the contacts can hold the motion)."""

    tau: np.ndarray
    contact_forces: np.ndarray
    residual: float | np.ndarray

    @classmethod
    def from_json(
        cls, body: Mapping[str, Any], batched: bool, rows: int | None
    ) -> ContactInverseDynamics:
        residual = read(body, "residual", 0, batched, rows)
        return cls(
            read(body, "tau", 1, batched, rows),
            read(body, "contact_forces", 1, batched, rows),
            residual if batched else float(residual),
        )


class ImpulseDynamics(NamedTuple):
    """A rigid impact: `v` (nv,) just after, and `contact_impulses` Λ (m,), N·s and N·m·s,
    with M (v⁺ − v⁻) = Jcᵀ Λ and Jc v⁺ = −e Jc v⁻; a leading axis N for a batch."""

    v: np.ndarray
    contact_impulses: np.ndarray

    @classmethod
    def from_json(cls, body: Mapping[str, Any], batched: bool, rows: int | None) -> ImpulseDynamics:
        return cls(
            read(body, "v", 1, batched, rows), read(body, "contact_impulses", 1, batched, rows)
        )


class ContactTrajectory(NamedTuple):
    """A trajectory simulated with contacts: like `Trajectory` (t, q, v, mechanical_energy)
    plus `constraint_drift` (steps + 1,), the largest distance (m) of a contact frame's
    origin from where it started, at each sample."""

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    mechanical_energy: np.ndarray
    constraint_drift: np.ndarray

    @classmethod
    def from_json(
        cls, body: Mapping[str, Any], batched: bool, rows: int | None
    ) -> ContactTrajectory:
        return cls(*trajectory_arrays(body, cls._fields, batched, rows))
