"""Payloads: rigid bodies held by a frame, which every computing method takes as `payloads=`.

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
        default=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))

    def __post_init__(self) -> None:
        """Check the payload (`InputError`) and keep its vectors as tuples of floats, so that
        payloads compare and hash by value."""
        body = _payload_json("Payload", self.frame, self.mass, self.center_of_mass,
                             self.inertia)
        object.__setattr__(self, "mass", body["mass"])
        object.__setattr__(self, "center_of_mass", tuple(body["center_of_mass"]))
        object.__setattr__(self, "inertia", tuple(tuple(row) for row in body["inertia"]))

    def to_json(self) -> dict[str, Any]:
        """The payload as the server reads it: `{"frame", "mass", "center_of_mass",
        "inertia"}`."""
        return _payload_json("Payload", self.frame, self.mass, self.center_of_mass,
                             self.inertia)


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


def _payload_json(where: str, frame: Any, mass: Any, center_of_mass: Any, inertia: Any
                  ) -> dict[str, Any]:
    if not isinstance(frame, str) or not frame:
        raise InputError(f"{where}: frame must be a frame name (a non-empty str)")
    if (isinstance(mass, bool) or not isinstance(mass, numbers.Real)
            or not math.isfinite(mass)):
        raise InputError(f"{where}: mass must be a finite number of kg, not {mass!r}")
    return {"frame": frame, "mass": float(mass),
            "center_of_mass": _numbers(f"{where}: center_of_mass", center_of_mass, (3,)),
            "inertia": _numbers(f"{where}: inertia", inertia, (3, 3))}


def payloads_body(payloads: PayloadsLike | None) -> dict[str, Any]:
    """The `payloads` body member (empty for None or an empty list, so requests without
    payloads are unchanged)."""
    if payloads is None:
        return {}
    if isinstance(payloads, Payload | Mapping | str) or not isinstance(payloads, Sequence):
        raise InputError("payloads must be a list of Payload (or of mappings with 'frame' and "
                         "'mass'); for one payload give [payload]")
    out = []
    for k, payload in enumerate(payloads):
        where = f"payloads[{k}]"
        if isinstance(payload, Payload):
            out.append(payload.to_json())  # checked when it was made
            continue
        if not isinstance(payload, Mapping):
            raise InputError(f"{where} must be a Payload or a mapping, not "
                             f"{type(payload).__name__}")
        unknown = set(payload) - set(FIELDS)
        if unknown or "frame" not in payload or "mass" not in payload:
            raise InputError(f"{where} needs 'frame' and 'mass' and may have "
                             f"'center_of_mass' and 'inertia', nothing else")
        out.append(_payload_json(where, payload["frame"], payload["mass"],
                                 payload.get("center_of_mass", np.zeros(3)),
                                 payload.get("inertia", np.zeros((3, 3)))))
    return {"payloads": out} if out else {}
