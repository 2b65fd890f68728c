"""Joint-space vectors keyed by joint name, in requests and (on request) in answers.

Instead of an array, a joint-space input may be an object keyed by joint name, in any order:
every joint of the robot must be named once, and each takes its entries of that space — a
number (or a 1-list) for a 1-dof joint, `[cos θ, sin θ]` for a continuous joint's q, the
7-vector `[x, y, z, qx, qy, qz, qw]` for a free-flyer's q and its 6-vector in v, a and τ. A batch
is a list of such objects, one per state. `by_name` turns answers the other way round:
`{"joint": value}` for one state and a list of objects for a batch (or a trajectory).

Conversion is done here once, in the layer that parses requests; the rest of the service only
sees arrays. Plain-array requests never reach this module (`any_named` is a type check).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from service.errors import DimensionMismatch, did_you_mean
from service.registry.robot import Robot
from service.states import SPACES

_SHOWN = 20  # names listed at most in an error
_NAME_CHARS = 64  # characters of an unknown name shown at most


def is_named(value: Any) -> bool:
    """True for a name-keyed object, or a list of them (a batch)."""
    return type(value) is dict or (type(value) is list and len(value) > 0
                                   and type(value[0]) is dict)


def any_named(arrays: Mapping[str, Any]) -> bool:
    return any(is_named(value) for value in arrays.values())


def _layout(robot: Robot, dim: str) -> dict[str, tuple[int, int, str]]:
    """Joint name → (start, size, type) in the space of dimension `dim` ("nq" or "nv")."""
    start = "idx_q" if dim == "nq" else "idx_v"
    return {j["name"]: (j[start], j[dim], j["type"]) for j in robot.info()["joints"]
            if j[dim] > 0}


def _names(names: Iterable[str]) -> list[str]:
    shown = [n if len(n) <= _NAME_CHARS else n[:_NAME_CHARS] + "…" for n in names]
    return shown[:_SHOWN] + ([f"… {len(shown) - _SHOWN} more"] if len(shown) > _SHOWN else [])


def _state(robot: Robot, field: str, value: Mapping[str, Any], dim: str,
           layout: dict[str, tuple[int, int, str]]) -> np.ndarray:
    missing = [name for name in layout if name not in value]
    unknown = [name for name in value if name not in layout]
    if missing or unknown:
        parts = []
        if missing:
            parts.append(f"missing joints: {', '.join(_names(missing))}")
        if unknown:
            parts.append("unknown names: " + ", ".join(
                name + did_you_mean(name, missing) for name in _names(unknown)))
        raise DimensionMismatch(
            f"{field} by joint name must name every joint of robot '{robot.id}' once "
            f"({'; '.join(parts)}); the joints are listed under `joints` in "
            f"GET /v1/robots/{robot.id}", missing=_names(missing), unknown=_names(unknown))
    out = np.empty(getattr(robot, dim))
    for name, (start, size, kind) in layout.items():
        entry = np.asarray(value[name], dtype=np.float64)
        if entry.size != size or entry.ndim > 1:
            has = "a number" if entry.ndim == 0 else f"{entry.size} entries"
            takes = "a number" if size == 1 else f"{size} numbers"
            raise DimensionMismatch(f"{field}['{name}'] has {has}; joint '{name}' ({kind}) "
                                    f"takes {takes} in {field}")
        out[start:start + size] = entry
    return out


def from_names(robot: Robot, field: str, value: Any, dim: str) -> Any:
    """The array form of `value` for the space of dimension `dim` ("nq" or "nv"): (n,) for an
    object, (N, n) for a list of objects; any other value is returned unchanged."""
    if not is_named(value):
        return value
    layout = _layout(robot, dim)
    if type(value) is dict:
        return _state(robot, field, value, dim, layout)
    if not all(type(v) is dict for v in value):
        raise DimensionMismatch(f"{field} mixes joint-name objects and arrays; a batch is a "
                                "list of objects or a list of arrays")
    return np.stack([_state(robot, f"{field}[{i}]", v, dim, layout)
                     for i, v in enumerate(value)])


def arrays_from_names(robot: Robot, arrays: Mapping[str, Any]) -> dict[str, Any]:
    """The joint-space inputs (keys of `service.states.SPACES`) with name-keyed ones as arrays."""
    return {name: from_names(robot, name, value, SPACES[name]) for name, value in arrays.items()}


def by_name(robot: Robot, results: Mapping[str, Any], fields: Iterable[str]) -> dict[str, Any]:
    """`results` with each of `fields` (joint-space vectors: last axis nq for "q", else nv)
    keyed by joint name: an object for a vector, a (nested) list of objects for more axes."""
    out = dict(results)
    for field in fields:
        if field not in out:
            continue
        layout = _layout(robot, "nq" if field == "q" else "nv")
        parts = [(name, start, size) for name, (start, size, _) in layout.items()]
        out[field] = _keyed(np.asarray(out[field]), parts)
    return out


def _keyed(values: np.ndarray, parts: list[tuple[str, int, int]]) -> Any:
    if values.ndim > 1:
        return [_keyed(row, parts) for row in values]
    return {name: float(values[start]) if size == 1 else values[start:start + size].tolist()
            for name, start, size in parts}
