"""The request layer's inputs: joint-space vectors keyed by joint name, converted once, here;
the states of a request validated (`prepare_states`); and the robot a request computes with
(`robot_for`).

Instead of an array, a joint-space input may be an object keyed by joint name, in any order,
as a ROS `sensor_msgs/JointState` holds it: each joint takes its entries of that space — a
number (or a 1-list) for a 1-dof joint; for a continuous joint's q its angle θ (rad) or
`[cos θ, sin θ]`; for a planar joint's q `[x, y, θ]` or `[x, y, cos θ, sin θ]`; the 7-vector
`[x, y, z, qx, qy, qz, qw]` for a free-flyer's q and its 6-vector in v, a and τ; a spherical
joint's quaternion in the robot's q order (`[qw, qx, qy, qz]`, MuJoCo's, for a model built from
MJCF). A batch is a list of such objects, one per state.

Every joint must be named once, unless the request says how to fill the others (`"fill"`):
`"neutral"` or the name of one of the robot's reference configurations (e.g. `"standing"`)
gives a missing joint's q from that configuration; a missing joint's v, a and τ are zero.

A ROS `sensor_msgs/JointState` as JSON (`{"name": [...], "position": [...], "velocity": [...],
"effort": [...]}`, what rosbridge and `json.dumps` of a message give) is taken the same way:
q (and simulate's `q_target`) takes its positions, v its velocities, τ its efforts, one number
per name; a list of them is a batch. A joint named twice — in a JointState or, in a JSON body,
as a key given twice in one object (JSON parsers keep the last silently) — is a 422 naming it.

`by_name` turns answers the other way round: `{"joint": value}` for one state and a list of
objects for a batch (or a trajectory).

Conversion is done here once, in the layer that parses requests; the rest of the service only
sees arrays. Plain-array requests pay only a type check (`any_named`). Options that may be
keyed by joint name are declared by their quantity (`Quantity.named_options`, e.g. simulate's
`tau` and controller gains) and converted by `options_from_names`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from pydantic import ValidationError

from service.api.schemas.common import JointState
from service.dynamics import Quantity
from service.dynamics.payloads import robot_with_payloads
from service.errors import DimensionMismatch, InvalidInput, did_you_mean
from service.registry.robot import Robot
from service.states import SPACES, States, prepare

_SHOWN = 20  # names listed at most in an error
_NAME_CHARS = 64  # characters of an unknown name shown at most


def is_named(value: Any) -> bool:
    """True for a name-keyed object or a JointState, or a list of them (a batch)."""
    kind = type(value[0]) if type(value) is list and len(value) > 0 else type(value)
    return kind is dict or kind is JointState


# Which of a JointState's vectors a joint-space input (by its field's last name) takes.
_JOINT_STATE_VECTORS = {"q": "position", "q_target": "position", "v": "velocity", "tau": "effort"}
_JOINT_STATE_KEYS = frozenset(("name", "position", "velocity", "effort", "header"))


def _joint_state(value: Any) -> JointState | None:
    """`value` as a JointState: the model itself, or its dump (an option's `model_dump`)."""
    if type(value) is JointState:
        return value
    if (
        type(value) is dict
        and type(value.get("name")) is list
        and value.keys() <= _JOINT_STATE_KEYS
    ):
        try:
            return JointState.model_validate(value)
        except ValidationError:  # e.g. joints called "name" and "position": keyed by name
            return None
    return None


def _from_joint_state(state: JointState, field: str) -> dict[str, Any]:
    """The name-keyed object of `state`'s vector that `field` takes (positions for q, ...)."""
    leaf = field.split("[")[0].rsplit(".", 1)[-1]
    vector = _JOINT_STATE_VECTORS.get(leaf)
    if vector is None:
        raise InvalidInput(
            f"{field} cannot be given as a JointState (it has positions for q, "
            "velocities for v and efforts for τ); give an object keyed by joint "
            "name or an array"
        )
    values = getattr(state, vector)
    if len(values) != len(state.name):
        raise DimensionMismatch(
            f"{field} as a JointState takes its `{vector}`, one number per "
            f"name: it has {len(values)} for {len(state.name)} names"
        )
    by_name = dict(zip(state.name, values, strict=True))
    if len(by_name) != len(state.name):
        seen: set[str] = set()
        for name in state.name:
            if name in seen:
                raise InvalidInput(
                    f"{field} names joint '{_names([name])[0]}' twice; name each joint once"
                )
            seen.add(name)
    return by_name


def any_named(arrays: Mapping[str, Any]) -> bool:
    return any(is_named(value) for value in arrays.values())


def _layout(robot: Robot, dim: str) -> dict[str, tuple[int, int, str]]:
    """Joint name → (start, size, type) in the space of dimension `dim` ("nq" or "nv")."""
    start = "idx_q" if dim == "nq" else "idx_v"
    return {j["name"]: (j[start], j[dim], j["type"]) for j in robot.info()["joints"] if j[dim] > 0}


def _names(names: Iterable[str]) -> list[str]:
    shown = [n if len(n) <= _NAME_CHARS else n[:_NAME_CHARS] + "…" for n in names]
    return shown[:_SHOWN] + ([f"… {len(shown) - _SHOWN} more"] if len(shown) > _SHOWN else [])


NEUTRAL = "neutral"


def fill_values(robot: Robot, fill: str | None, dim: str) -> np.ndarray | None:
    """The vector missing joints take their entries from: the configuration named `fill` for
    q ("neutral" or a reference configuration), zeros for v, a and τ; None without `fill`."""
    if fill is None:
        return None
    if fill == NEUTRAL:
        base = np.asarray(robot.info()["neutral_configuration"], dtype=np.float64)
    elif fill in robot.reference_configurations:  # as the API gives it (`Robot.info`)
        base = np.asarray(robot.info()["reference_configurations"][fill], dtype=np.float64)
    else:
        choices = [NEUTRAL, *robot.reference_configurations]
        raise InvalidInput(
            f"fill {fill[:_NAME_CHARS]!r} is not a configuration of robot "
            f"'{robot.id}'; it takes one of {', '.join(_names(choices))}"
        )
    return base if dim == "nq" else np.zeros(robot.nv)


# A scalar angle θ (rad) stands for the (cos θ, sin θ) part of these joints' q entries.
_ANGLE_PART = {"continuous": 0, "planar": 2}


def _entry(kind: str, size: int, value: Any, dim: str) -> np.ndarray:
    entry = np.asarray(value, dtype=np.float64)
    if dim == "nq" and kind in _ANGLE_PART and entry.size == size - 1 and entry.ndim <= 1:
        at = _ANGLE_PART[kind]
        angle = entry.reshape(-1)[at]
        return np.concatenate([entry.reshape(-1)[:at], [math.cos(angle), math.sin(angle)]])
    return entry


def _state(
    robot: Robot,
    field: str,
    value: Mapping[str, Any],
    dim: str,
    layout: dict[str, tuple[int, int, str]],
    fill: np.ndarray | None = None,
) -> np.ndarray:
    missing = [name for name in layout if name not in value] if fill is None else []
    unknown = [name for name in value if name not in layout]
    if missing or unknown:
        parts = []
        if missing:
            parts.append(f"missing joints: {', '.join(_names(missing))}")
        if unknown:
            parts.append(
                "unknown names: "
                + ", ".join(name + did_you_mean(name, missing) for name in _names(unknown))
            )
        raise DimensionMismatch(
            f"{field} by joint name must name every joint of robot '{robot.id}' once "
            f"({'; '.join(parts)}), or the request must say how to fill the missing ones "
            '("fill": "neutral" or a reference configuration\'s name); the joints are listed '
            f"under `joints` in GET /v1/robots/{robot.id}",
            missing=_names(missing),
            unknown=_names(unknown),
        )
    out = np.empty(getattr(robot, dim)) if fill is None else fill.copy()
    for name, (start, size, kind) in layout.items():
        if name not in value:
            continue  # filled
        entry = _entry(kind, size, value[name], dim)
        if entry.size != size or entry.ndim > 1:
            has = "a number" if entry.ndim == 0 else f"{entry.size} entries"
            takes = "a number" if size == 1 else f"{size} numbers"
            if dim == "nq" and kind == "continuous":
                takes = "an angle or [cos θ, sin θ]"
            elif dim == "nq" and kind == "planar":
                takes = "[x, y, θ] or [x, y, cos θ, sin θ]"
            raise DimensionMismatch(
                f"{field}['{name}'] has {has}; joint '{name}' ({kind}) takes {takes} in {field}"
            )
        out[start : start + size] = entry
    return out


def from_names(robot: Robot, field: str, value: Any, dim: str, fill: str | None = None) -> Any:
    """The array form of `value` for the space of dimension `dim` ("nq" or "nv"): (n,) for an
    object, (N, n) for a list of objects; any other value is returned unchanged. `fill`: how
    missing joints are filled (see the module's docstring); None: every joint must be named."""
    if not is_named(value):
        return value
    layout = _layout(robot, dim)
    base = fill_values(robot, fill, dim)
    if type(value) is not list:
        return _state(robot, field, _mapping(value, field), dim, layout, base)
    if not all(type(v) is dict or type(v) is JointState for v in value):
        raise DimensionMismatch(
            f"{field} mixes joint-name objects and arrays; a batch is a "
            "list of objects or a list of arrays"
        )
    return np.stack(
        [
            _state(robot, f"{field}[{i}]", _mapping(v, f"{field}[{i}]"), dim, layout, base)
            for i, v in enumerate(value)
        ]
    )


def _mapping(value: Any, field: str) -> Mapping[str, Any]:
    """A name-keyed object (as it is) or a JointState's vector for `field`, keyed by name."""
    state = _joint_state(value)
    return value if state is None else _from_joint_state(state, field)


def arrays_from_names(
    robot: Robot, arrays: Mapping[str, Any], fill: str | None = None
) -> dict[str, Any]:
    """The joint-space inputs (keys of `service.states.SPACES`) with name-keyed ones as arrays;
    `fill` as for `from_names`."""
    return {
        name: from_names(robot, name, value, SPACES[name], fill) for name, value in arrays.items()
    }


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


def joint_layout(robot: Robot, results: Mapping[str, Any], fields: Iterable[str]) -> dict[str, Any]:
    """`results` as they are (the joint-space vectors stay arrays), with `joint_names`: for
    each of `fields` present, its joints as `[name, start, size]` over the last axis (nq
    for "q", else nv). The binary form's answer with `"joint_names": true`: the names once,
    not per row (a 40,000-step trajectory keyed per row made a header of 100 MB)."""
    out = dict(results)
    out["joint_names"] = {
        field: [
            [name, start, size]
            for name, (start, size, _) in _layout(robot, "nq" if field == "q" else "nv").items()
        ]
        for field in fields
        if field in out
    }
    return out


def _keyed(values: np.ndarray, parts: list[tuple[str, int, int]]) -> Any:
    if values.ndim > 1:
        return [_keyed(row, parts) for row in values]
    return {
        name: float(values[start]) if size == 1 else values[start : start + size].tolist()
        for name, start, size in parts
    }


def prepare_states(
    robot: Robot,
    arrays: dict[str, Any],
    max_batch: int,
    fill: str | None = None,
    finite_later: frozenset[str] = frozenset(),
) -> States:
    """The validated `States` of a request's joint-space inputs; name-keyed ones become arrays
    first (missing joints filled from the configuration named `fill`, if given).
    `finite_later`: see `service.states.prepare`."""
    if any_named(arrays):  # a type check: plain arrays pay nothing measurable
        arrays = arrays_from_names(robot, arrays, fill)
    elif fill is not None:
        fill_values(robot, fill, "nq")  # an unknown name is an error all the same
    return prepare(robot, arrays, max_batch, finite_later)


def options_from_names(robot: Robot, quantity: Quantity, options: dict[str, Any]) -> dict[str, Any]:
    """`options` with the quantity's `named_options` given keyed by joint name as arrays
    (every joint named: `fill` applies to the joint-space inputs only)."""
    for path, dim in quantity.named_options:
        *parents, leaf = path.split(".")
        holder: Any = options
        for part in parents:
            holder = holder.get(part) if isinstance(holder, dict) else None
        if isinstance(holder, dict) and is_named(holder.get(leaf)):
            holder[leaf] = from_names(robot, path, holder[leaf], dim)
    return options


class _RepeatedName(Exception):
    def __init__(self, name: str) -> None:
        self.name = name


def _unique_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise _RepeatedName(key)
        out[key] = value
    return out


def refuse_repeated_names(body: bytes | bytearray | str) -> None:
    """422 for a JSON body in which one object gives a member twice (a joint named twice in a
    name-keyed input): JSON parsers keep the last value silently. Called only for bodies with
    name-keyed inputs (a second parse, with a check per object)."""
    try:
        json.loads(body, object_pairs_hook=_unique_pairs)
    except _RepeatedName as repeated:
        name = _names([repeated.name])[0]
        raise InvalidInput(
            f"'{name}' is given twice in one object of the body (a joint named "
            "twice?); JSON keeps only the last one: name each joint once"
        ) from None
    except (ValueError, RecursionError):  # the body was read as JSON already: not ours to judge
        pass


def names_keyed(quantity: Quantity, arrays: Mapping[str, Any], options: Mapping[str, Any]) -> bool:
    """True when a request's inputs or named options are keyed by joint name."""
    if any_named(arrays):
        return True
    for path, _ in quantity.named_options:
        holder: Any = options
        for part in path.split("."):
            holder = holder.get(part) if isinstance(holder, dict) else None
        if is_named(holder):
            return True
    return False


def robot_for(robot: Robot, options: dict[str, Any]) -> Robot:
    """The robot a request computes with. The one place where an option that modifies the
    model for every quantity alike turns the stored robot into the one computed with, before
    any quantity runs; such an option is popped from `options` here, so `compute` never sees
    it. `payloads`: the robot carrying them (`service.dynamics.payloads`: checked, composed
    into a copy of the model, cached per robot and payload set)."""
    payloads = options.pop("payloads", None)
    return robot_with_payloads(robot, payloads) if payloads else robot
