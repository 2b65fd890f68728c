"""Payloads: rigid bodies held by a frame, which every computing method takes as `payloads=`,
and the answer of `payload_capacity` (`PayloadCapacity`).

A payload is added rigidly to the body that carries its frame, so every quantity (M, g, τ, the
total mass, the centre of mass, ...) is that of the robot holding it. The server checks the
physics (mass > 0, inertia symmetric positive semidefinite with the triangle inequality) and
the frame name; the client checks the shapes and that every number is finite.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robodyn.errors import InputError


@dataclass(frozen=True)
class Payload:
    """A rigid body held by `frame` (a name from `RobotInfo.frame_names`): `mass` in kg (> 0),
    `center_of_mass` (3,) in m in the frame (default its origin), `inertia` (3, 3) in kg·m²
    about the payload's own centre of mass, in the frame's axes (default zero: a point mass).

        Payload("tool0", 3.0, center_of_mass=(0, 0, 0.05))
    """

    frame: str
    mass: float
    center_of_mass: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0)
    inertia: Sequence[Sequence[float]] | np.ndarray = field(
        default=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    )

    def __post_init__(self) -> None:
        """Check the payload (`InputError`) and keep its vectors as tuples of floats, so that
        payloads compare and hash by value."""
        body = _payload_json("Payload", self.frame, self.mass, self.center_of_mass, self.inertia)
        object.__setattr__(self, "mass", body["mass"])
        object.__setattr__(self, "center_of_mass", tuple(body["center_of_mass"]))
        object.__setattr__(self, "inertia", tuple(tuple(row) for row in body["inertia"]))

    def to_json(self) -> dict[str, Any]:
        """The payload as the server reads it: `{"frame", "mass", "center_of_mass",
        "inertia"}`."""
        return _payload_json("Payload", self.frame, self.mass, self.center_of_mass, self.inertia)


PayloadsLike = Sequence[Payload | Mapping[str, Any]]
"""A list of payloads: `Payload`s, or mappings with the same keys (`frame` and `mass` needed)."""
FIELDS = ("frame", "mass", "center_of_mass", "inertia")


def _numbers(where: str, value: Any, shape: tuple[int, ...]) -> list[Any]:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (ValueError, TypeError):
        raise InputError(f"{where} must be numbers of shape {shape}") from None
    if arr.shape != shape:
        raise InputError(f"{where} must have shape {shape}, not {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{where} must be finite")
    listed: list[Any] = arr.tolist()
    return listed


def _payload_json(
    where: str, frame: Any, mass: Any, center_of_mass: Any, inertia: Any
) -> dict[str, Any]:
    if not isinstance(frame, str) or not frame:
        raise InputError(f"{where}: frame must be a frame name (a non-empty str)")
    if isinstance(mass, bool) or not isinstance(mass, numbers.Real) or not math.isfinite(mass):
        raise InputError(f"{where}: mass must be a finite number of kg, not {mass!r}")
    return {
        "frame": frame,
        "mass": float(mass),
        "center_of_mass": _numbers(f"{where}: center_of_mass", center_of_mass, (3,)),
        "inertia": _numbers(f"{where}: inertia", inertia, (3, 3)),
    }


def payloads_body(payloads: PayloadsLike | None) -> dict[str, Any]:
    """The `payloads` body member (empty for None or an empty list, so requests without
    payloads are unchanged)."""
    if payloads is None:
        return {}
    if isinstance(payloads, Payload | Mapping | str) or not isinstance(payloads, Sequence):
        raise InputError(
            "payloads must be a list of Payload (or of mappings with 'frame' and "
            "'mass'); for one payload give [payload]"
        )
    out = []
    for k, payload in enumerate(payloads):
        where = f"payloads[{k}]"
        if isinstance(payload, Payload):
            out.append(payload.to_json())  # checked when it was made
            continue
        if not isinstance(payload, Mapping):
            raise InputError(
                f"{where} must be a Payload or a mapping, not {type(payload).__name__}"
            )
        unknown = set(payload) - set(FIELDS)
        if unknown or "frame" not in payload or "mass" not in payload:
            raise InputError(
                f"{where} needs 'frame' and 'mass' and may have "
                f"'center_of_mass' and 'inertia', nothing else"
            )
        out.append(
            _payload_json(
                where,
                payload["frame"],
                payload["mass"],
                payload.get("center_of_mass", np.zeros(3)),
                payload.get("inertia", np.zeros((3, 3))),
            )
        )
    return {"payloads": out} if out else {}


def _masses(value: Any) -> np.ndarray:
    """Masses of an answer (kg) as float64, `inf` where the server says null (nothing limits):
    from JSON (numbers and nulls, nested) or the binary form (arrays with inf already)."""
    if isinstance(value, np.ndarray):
        return value.astype(np.float64, copy=False)
    out = np.asarray(value if value is not None else np.inf, dtype=np.float64)
    return np.where(np.isnan(out), np.inf, out)


def _range(value: Any) -> tuple[float, float] | None:
    """A mass range [lo, hi] of an answer as (lo, hi) in kg, hi inf where the server says null
    (no upper end); None for an empty range."""
    if value is None:
        return None
    lo, hi = value
    return float(lo), float(np.inf if hi is None else hi)


@dataclass(frozen=True)
class CapacityMinimum:
    """The smallest capacity over a batch: `mass` (kg; inf when nothing limits any state), the
    first `state` (index) that has it, its `limiting_joint` (None when nothing limits), and
    `mass_range`, the masses (lo, hi) in kg that keep every joint within its limit at every
    state (hi inf: no upper end; None when no mass suits every state)."""

    mass: float
    state: int | None
    limiting_joint: str | None
    mass_range: tuple[float, float] | None = None


@dataclass(frozen=True, eq=False)
class PayloadCapacity:
    """The answer of `payload_capacity`: the heaviest point mass the frame can hold with no joint
    over its effort limit, exact (τ(m) = τ₀ + m τ₁ is affine in the mass m).

    `mass_range`: the masses m ≥ 0 with every joint within its limit form an interval,
    (lo, hi) in kg for one state (hi inf: no upper end; None: no mass suits every joint), an
    array (N, 2) for a batch (NaN rows where empty); lo > 0 when the load is what keeps a joint
    within its limit (a counterweight). `mass` is hi (kg: a float for one state, an array (N,)
    for a batch; `inf` where no joint limits it, 0 where the range is empty),
    `limiting_joint` (the joint that sets it; None where nothing limits; a tuple for a batch),
    `mass_per_joint` (nv,) or (N, nv) (the largest mass each velocity coordinate alone allows,
    kg; `inf` where it never limits, 0 where no mass suits it), `tau` (nv,) or (N, nv) (the
    torques at that mass, N·m or N) and, for a batch, `minimum` (`CapacityMinimum`: the
    smallest capacity over the batch, where it occurs and the masses that suit every state;
    else None).
    """

    mass: float | np.ndarray
    limiting_joint: str | tuple[str | None, ...] | None
    mass_per_joint: np.ndarray
    tau: np.ndarray
    minimum: CapacityMinimum | None = None
    mass_range: tuple[float, float] | np.ndarray | None = None

    @classmethod
    def from_json(cls, body: Mapping[str, Any], batched: bool, rows: int | None) -> PayloadCapacity:
        mass = _masses(body["mass"])
        per = _masses(body["mass_per_joint"])
        tau = np.asarray(body["tau"], dtype=np.float64)
        expected = 1 if batched else 0
        if mass.ndim != expected or per.ndim != expected + 1 or tau.shape != per.shape:
            raise ValueError("the payload-capacity answer does not have the shapes sent")
        if batched and rows is not None and mass.shape[0] != rows:
            raise ValueError(f"'mass' has {mass.shape[0]} states; {rows} were sent")
        joint = body.get("limiting_joint")
        if not batched:
            return cls(float(mass), joint, per, tau, mass_range=_range(body.get("mass_range")))
        low = body.get("minimum") or {}
        minimum = CapacityMinimum(
            mass=float(np.inf if low.get("mass") is None else low["mass"]),
            state=None if low.get("state") is None else int(low["state"]),
            limiting_joint=low.get("limiting_joint"),
            mass_range=_range(low.get("mass_range")),
        )
        ranges = np.array(
            [_range(x) or (np.nan, np.nan) for x in body.get("mass_range") or ()], dtype=np.float64
        ).reshape(-1, 2)
        return cls(mass, tuple(joint or ()), per, tau, minimum, ranges)
