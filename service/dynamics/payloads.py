"""Payloads of a request: checked, composed into a copy of the robot's model, and cached.

A request's `payloads` is a list (at most `MAX_PAYLOADS`) of rigid bodies, each held by a frame:

    {"frame": name, "mass": m, "center_of_mass": [cx, cy, cz], "inertia": [[...], [...], [...]]}

- `frame`: any frame of the model (link, joint or fixed frame; the frame rule of every route,
  `service.dynamics.frames.frame_id`);
- `mass` m: kg, finite and > 0;
- `center_of_mass` c: m, in the frame's axes from its origin (default the origin);
- `inertia` I_c: kg·m², about the payload's own centre of mass, in the frame's axes (default
  zero: a point mass); finite, symmetric (within 1e-9 of its largest entry), positive
  semidefinite and with the triangle inequality λ₁ + λ₂ ≥ λ₃ on its principal moments, with the
  tolerances of uploads (`service.registry.urdf_check`).

`robot_with_payloads(robot, payloads)` is the robot carrying them (`service.registry.payloads`:
inertias[frame.parentJoint] += frame.placement · Inertia(m, c, I_c), on a copy of the model), a
`Robot` with its own Data pool, built once per (robot, payload set) and kept in a small least
recently used cache. Every mistake is a domain error naming the payload by its index:
`InvalidInput` (`validation_error`) with the field, or `UnknownFrame` (`unknown_frame`).
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from service.dynamics.frames import frame_id
from service.errors import InvalidInput
from service.registry.inertia_rules import ABS_TOL, NEGATIVE_REL_TOL, TRIANGLE_REL_TOL
from service.registry.payloads import PlacedPayload, canonical, carrying
from service.registry.robot import Robot

MAX_PAYLOADS = 16
SYMMETRY_TOL = 1e-9  # |I − Iᵀ| allowed, relative to the largest |entry| of I
CACHE_SIZE = 16  # payload-carrying robots kept (each holds a model copy and its Datas)

PayloadLike = Mapping[str, Any] | PlacedPayload


def _invalid(index: int, field: str, reason: str) -> InvalidInput:
    return InvalidInput(f"payloads[{index}].{field} {reason}", payload=index, field=field)


def _numbers(index: int, field: str, value: Any, shape: tuple[int, ...]) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (ValueError, TypeError):
        raise _invalid(index, field, "must hold numbers") from None
    if arr.shape != shape:
        wanted = "3 numbers" if shape == (3,) else "a 3×3 matrix (3 rows of 3 numbers)"
        raise _invalid(index, field, f"must be {wanted}")
    if not np.isfinite(arr).all():
        raise _invalid(index, field, "contains a non-finite number (NaN or infinity)")
    return arr


MAX_INERTIA = 1e12  # kg·m²: no rigid body a robot holds comes near it


def check_inertia(index: int, inertia: np.ndarray) -> np.ndarray:
    """I_c symmetrized, or `InvalidInput` if it is not symmetric, not positive semidefinite
    or breaks the triangle inequality (kg·m², see the module docstring)."""
    largest = float(np.max(np.abs(inertia)))
    if largest > MAX_INERTIA:  # beyond any body, and past what an eigen-solve can square
        raise _invalid(
            index,
            "inertia",
            f"has an entry of {largest:.3g} kg·m²: at most {MAX_INERTIA:.0e} kg·m² in magnitude",
        )
    if np.max(np.abs(inertia - inertia.T)) > SYMMETRY_TOL * largest:
        raise _invalid(index, "inertia", "must be symmetric (I[i][j] = I[j][i])")
    inertia = 0.5 * (inertia + inertia.T)
    moments = np.linalg.eigvalsh(inertia)
    shown = ", ".join(f"{m:.6g}" for m in moments)
    if moments[0] < -(NEGATIVE_REL_TOL * largest + ABS_TOL):
        raise _invalid(
            index,
            "inertia",
            f"must be positive semidefinite; its principal moments are {shown} kg·m²",
        )
    if moments[0] + moments[1] < moments[2] - (TRIANGLE_REL_TOL * float(moments.sum()) + ABS_TOL):
        raise _invalid(
            index,
            "inertia",
            f"breaks the triangle inequality of a rigid body "
            f"(λ₁ + λ₂ ≥ λ₃); its principal moments are {shown} kg·m²",
        )
    return inertia


def check_payload(robot: Robot, index: int, payload: PayloadLike) -> PlacedPayload:
    """One payload of a request, checked against `robot` (see the module docstring)."""
    if isinstance(payload, PlacedPayload):
        payload = payload.as_dict()
    if not isinstance(payload, Mapping):
        raise InvalidInput(
            f"payloads[{index}] must be an object with frame, mass, center_of_mass and inertia",
            payload=index,
        )
    frame = payload.get("frame")
    if not isinstance(frame, str):
        raise _invalid(index, "frame", "must name a frame of the robot")
    frame_id(robot, frame, f"payloads[{index}].frame")
    mass = payload.get("mass")
    if isinstance(mass, bool) or not isinstance(mass, int | float):
        raise _invalid(index, "mass", "must be a number (kg)")
    if not math.isfinite(mass) or mass <= 0:
        shown = f"{mass:.6g} kg" if math.isfinite(mass) else "not finite"
        raise _invalid(index, "mass", f"must be finite and > 0 kg; it is {shown}")
    com = payload.get("center_of_mass")
    c = np.zeros(3) if com is None else _numbers(index, "center_of_mass", com, (3,))
    given = payload.get("inertia")
    inertia = (
        np.zeros((3, 3))
        if given is None
        else check_inertia(index, _numbers(index, "inertia", given, (3, 3)))
    )
    return PlacedPayload(
        frame,
        float(mass),
        (float(c[0]), float(c[1]), float(c[2])),
        tuple(tuple(float(x) for x in row) for row in inertia),
    )


def check_payloads(robot: Robot, payloads: Sequence[PayloadLike]) -> tuple[PlacedPayload, ...]:
    """Every payload checked (the first mistake raised), in canonical order."""
    if len(payloads) > MAX_PAYLOADS:
        raise InvalidInput(
            f"payloads has {len(payloads)} entries; at most {MAX_PAYLOADS} are "
            "allowed (combine payloads held by one frame into one)"
        )
    return canonical([check_payload(robot, i, p) for i, p in enumerate(payloads)])


class RobotCache:
    """Derived robots (model copies) keyed by (base model, base id, key), least recently used
    dropped beyond `size`. Thread-safe; a robot is built outside the lock (two threads may
    build the same one at once: both answers are right, one is kept)."""

    def __init__(self, size: int) -> None:
        self.size = size
        self._lock = threading.Lock()
        self._items: OrderedDict[tuple[Any, ...], tuple[Any, Robot]] = OrderedDict()

    def get(self, robot: Robot, key: tuple[Any, ...], build: Callable[[], Robot]) -> Robot:
        full = (id(robot.model), robot.id, key)
        with self._lock:
            hit = self._items.get(full)
            if hit is not None and hit[0] is robot.model:
                self._items.move_to_end(full)
                return hit[1]
        built = build()
        with self._lock:
            self._items[full] = (robot.model, built)  # holding the model keeps its id() unique
            self._items.move_to_end(full)
            while len(self._items) > self.size:
                self._items.popitem(last=False)
        return built


_carrying = RobotCache(CACHE_SIZE)


def robot_with_payloads(robot: Robot, payloads: Sequence[PayloadLike] | None) -> Robot:
    """`robot` carrying `payloads` (checked here): a `Robot` whose model is a copy with the
    payloads' inertias added, with its own Data pool and the same id (error messages name the
    robot of the request). No payloads: `robot` itself. Cached per (robot, payload set)."""
    if not payloads:
        return robot
    placed = check_payloads(robot, payloads)
    return _carrying.get(robot, tuple(p.key() for p in placed), lambda: carrying(robot, placed))
