"""Joint-space arrays in and out: local checks before sending, shape checks on answers.

A 1-D array is one state; a 2-D array of shape (N, n) is a batch of N states, and then every
answer gains a leading axis of length N. All inputs of one request are 1-D, or all are 2-D with
the same N. Inputs must be real numbers (bool, complex, text and objects are refused) and
finite. Lengths against the robot's nq and nv are checked by the server, which knows them.

Any array-like is accepted: lists, numpy arrays, torch tensors (on any device; detached and
copied to the CPU), JAX arrays and anything with `__array__`. The dtype rule: every input is
converted to float64 before it is sent, which is exact for float16, float32 and integers up
to 2**53 (a float32 0.1 is sent as 0.100000001490116…, the value it holds); answers are always
float64. Inputs may also be keyed by joint name: a mapping, or a ROS `sensor_msgs/JointState`
-like object (see `joint_state`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol, TypeAlias

import numpy as np
import numpy.typing as npt

from robodyn.errors import InputError


class JointStateLike(Protocol):
    """A ROS `sensor_msgs/JointState`-like object: joint `name`s and, in the same order, their
    `position`, `velocity` and `effort` (the last two may be missing or empty)."""

    @property
    def name(self) -> Any: ...

    @property
    def position(self) -> Any: ...


ArrayLike: TypeAlias = (
    npt.ArrayLike
    | Mapping[str, Any]
    | Sequence[Mapping[str, Any]]
    | JointStateLike
    | Sequence[JointStateLike]
)
"""A joint-space input: anything numpy reads as a 1-D or 2-D array of real numbers (list,
tuple, ndarray, torch tensor, JAX array), or an input keyed by joint name (a mapping, a
JointState-like object, or a list of them for a batch)."""


def host_array(value: Any) -> Any:
    """`value` made readable by numpy without importing its library: a torch tensor detached
    and moved to the CPU (`Tensor.numpy()` refuses tensors that need grad or live on a GPU);
    everything else as is (numpy reads JAX arrays and others through `__array__`)."""
    if type(value).__module__.startswith("torch") and hasattr(value, "detach"):
        return value.detach().cpu().numpy()
    return value


def joint_array(name: str, value: ArrayLike, finite: bool = True) -> np.ndarray:
    """`value` as a float64 array of 1 or 2 dimensions, checked finite unless `finite` is
    False (the caller checks it later with `check_finite`); `InputError` naming `name`."""
    try:
        arr = np.asarray(host_array(value))
    except (ValueError, TypeError):  # ragged nested lists
        raise InputError(
            f"{name} must be a 1-D array (one state) or a 2-D array of equal-length "
            "rows (a batch); it is ragged or not an array"
        ) from None
    if arr.dtype.kind not in "iuf":
        kind = {
            "b": "booleans",
            "c": "complex numbers",
            "U": "text",
            "S": "bytes",
            "O": "objects",
        }.get(arr.dtype.kind, f"dtype {arr.dtype}")
        raise InputError(f"{name} must hold real numbers, not {kind}")
    if arr.ndim not in (1, 2):
        shape = "a scalar" if arr.ndim == 0 else f"{arr.ndim}-D, shape {arr.shape}"
        raise InputError(f"{name} must be 1-D (one state) or 2-D (a batch of states), not {shape}")
    arr = arr.astype(np.float64, copy=False)
    if arr.shape[-1] == 0:
        raise InputError(f"{name} is empty; it needs the robot's nq (for q) or nv entries")
    if arr.ndim == 2 and arr.shape[0] == 0:
        raise InputError(f"{name} is an empty batch; send at least one state")
    if finite:
        check_finite(name, arr)
    return arr


def check_finite(name: str, arr: np.ndarray) -> None:
    """`InputError` naming the first non-finite entry of the float64 array `arr` (of the
    input `name`), if it holds one."""
    if np.isfinite(arr).all():  # one pass; the first bad entry is looked for only on failure
        return
    bad = np.argwhere(~np.isfinite(arr))
    where = f"[{', '.join(str(int(i)) for i in bad[0])}]"
    raise InputError(f"{name}{where} is {arr[tuple(bad[0])]}; every entry must be finite")


def is_by_name(value: Any) -> bool:
    """True for a joint-space input keyed by joint name: a mapping, or a list of mappings."""
    return isinstance(value, Mapping) or (
        isinstance(value, list | tuple)
        and len(value) > 0
        and all(isinstance(v, Mapping) for v in value)
    )


def _by_name_state(name: str, value: Mapping[Any, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for joint, entry in value.items():
        if not isinstance(joint, str):
            raise InputError(
                f"{name} by joint name: keys must be joint names (str), not {type(joint).__name__}"
            )
        entry = host_array(entry)
        arr = joint_array(f"{name}[{joint!r}]", np.atleast_1d(np.asarray(entry)))
        if arr.ndim != 1:
            raise InputError(f"{name}[{joint!r}] must be a number or a list of numbers")
        out[joint] = float(arr[0]) if np.ndim(entry) == 0 else arr.tolist()
    return out


JOINT_STATE_FIELDS = {"q": "position", "v": "velocity", "tau": "effort"}
"""Which member of a JointState-like object each input takes (there is none for `a`)."""


def is_joint_state(value: Any) -> bool:
    """True for a ROS `sensor_msgs/JointState`-like object: `name` and `position` members."""
    return (
        not isinstance(value, Mapping | np.ndarray)
        and hasattr(value, "name")
        and hasattr(value, "position")
    )


def joint_state(name: str, value: Any) -> dict[str, Any]:
    """The mapping joint name → entry of a JointState-like object (`name`, `position`,
    `velocity`, `effort`, as in ROS) for input `name`: q takes `position`, v `velocity`, τ
    `effort`. A continuous joint's position is its angle (the server takes it as such)."""
    member = JOINT_STATE_FIELDS.get(name.split("[", 1)[0])
    if member is None:
        raise InputError(
            f"{name} cannot come from a JointState (it has positions, velocities "
            "and efforts, no accelerations): give an array or a mapping"
        )
    raw = getattr(value, member, None)
    names, values = list(value.name), ([] if raw is None else list(raw))
    if len(values) != len(names):
        raise InputError(
            f"{name} from a JointState: {member} has {len(values)} entries for "
            f"{len(names)} names (ROS leaves it empty when unknown)"
        )
    return dict(zip(names, values, strict=True))


def joint_input(
    name: str, value: Any, finite: bool = True
) -> np.ndarray | dict[str, Any] | list[dict[str, Any]]:
    """A joint-space input: a checked array (see `joint_array`), or — keyed by joint name — a
    JSON-ready object (one state) or list of objects (a batch), from mappings or JointState-like
    objects. Names are checked by the server, which knows the robot's joints. `finite`: as
    for `joint_array`."""
    if is_joint_state(value):
        value = joint_state(name, value)
    elif isinstance(value, list | tuple) and value and all(map(is_joint_state, value)):
        value = [joint_state(name, v) for v in value]
    if isinstance(value, Mapping):
        return _by_name_state(name, value)
    if is_by_name(value):
        return [_by_name_state(f"{name}[{i}]", v) for i, v in enumerate(value)]
    return joint_array(name, value, finite)


def _ndim(value: Any) -> int:
    return value.ndim if isinstance(value, np.ndarray) else (2 if isinstance(value, list) else 1)


def _rows(value: Any) -> int:
    return value.shape[0] if isinstance(value, np.ndarray) else len(value)


def joint_states(**inputs: Any) -> tuple[dict[str, Any], bool]:
    """Check the named inputs together: (arrays, batched). Refuses a mix of single states and
    batches, and batches of different sizes. Inputs keyed by joint name stay JSON objects."""
    arrays, batched, _ = large_joint_states(inputs, None)
    return arrays, batched


FINITE_WHEN_SENT_FROM = 8192
"""Numbers in a request's joint-space arrays from which their finiteness is checked when the
request is sent (`Call.check_finite`), not when it is made: a body through shared memory is
checked by the server, and the client checks it only when the server refuses it, with the
same `InputError` (10,000 Talos states: 0.7 ms of the call saved)."""


def large_joint_states(
    inputs: Mapping[str, Any], finite_when_sent_from: int | None = FINITE_WHEN_SENT_FROM
) -> tuple[dict[str, Any], bool, tuple[str, ...]]:
    """`joint_states` of `inputs`, and the names of the arrays whose finiteness is left to be
    checked when the request is sent: all of them when they hold `finite_when_sent_from`
    numbers or more (None: never)."""
    counts = [np.size(v) for v in inputs.values() if isinstance(v, np.ndarray)]
    later = (
        finite_when_sent_from is not None
        and len(counts) == len(inputs)
        and sum(counts) >= finite_when_sent_from
    )
    arrays = {name: joint_input(name, value, not later) for name, value in inputs.items()}
    ndims = {_ndim(arr) for arr in arrays.values()}
    if len(ndims) > 1:
        shown = ", ".join(f"{n} is {_ndim(a)}-D" for n, a in arrays.items())
        raise InputError(
            f"inputs mix single states and batches ({shown}); give all as 1-D or "
            "all as 2-D arrays (np.tile repeats a state N times)"
        )
    batched = ndims == {2}
    if batched:
        sizes = {n: _rows(a) for n, a in arrays.items()}
        if len(set(sizes.values())) > 1:
            shown = ", ".join(f"{n} has {s}" for n, s in sizes.items())
            raise InputError(
                f"batch sizes differ ({shown} states); every input needs the same number of states"
            )
    return arrays, batched, tuple(arrays) if later else ()


def to_json(arrays: Mapping[str, Any]) -> dict[str, Any]:
    """Arrays as nested lists of Python floats (JSON numbers round-trip float64 exactly);
    inputs keyed by joint name are JSON already."""
    return {
        name: arr.tolist() if isinstance(arr, np.ndarray) else arr for name, arr in arrays.items()
    }


def batch_rows(arrays: Mapping[str, Any], batched: bool) -> int | None:
    """The number of states of a batch (None for a single state)."""
    return _rows(next(iter(arrays.values()))) if batched else None


def answer_array(
    body: Mapping[str, Any],
    key: str,
    ndim: int,
    batched: bool,
    rows: int | None = None,
    square: bool = True,
) -> np.ndarray:
    """Field `key` of an answer as a float64 array with `ndim` dimensions per state (one more
    when `batched`, with `rows` states; a matrix must be square unless `square` is False).
    Raises KeyError/ValueError when it does not fit."""
    arr = np.asarray(body[key], dtype=np.float64)
    expected = ndim + 1 if batched else ndim
    if arr.ndim != expected:
        raise ValueError(f"'{key}' has {arr.ndim} dimensions; expected {expected}")
    if batched and rows is not None and arr.shape[0] != rows:
        raise ValueError(f"'{key}' has {arr.shape[0]} states; {rows} were sent")
    if square and ndim == 2 and arr.shape[-1] != arr.shape[-2]:
        raise ValueError(f"'{key}' is not square: shape {arr.shape}")
    return arr


def gravity_vector(value: ArrayLike) -> list[float]:
    """A gravity vector (m/s², world frame) checked to be 3 finite numbers."""
    arr = joint_array("gravity", value)
    if arr.shape != (3,):
        raise InputError(f"gravity must have 3 entries (x, y, z in m/s²), not shape {arr.shape}")
    return [float(x) for x in arr]
