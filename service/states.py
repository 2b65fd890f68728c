"""Joint states from requests: shapes, batches, finiteness and configuration checks.

A 1-D array is one state and a 2-D array `[N][n]` is a batch of N states; every input of one
request has the same N. Everything is checked here, before Pinocchio is called, and errors say
what was expected ("q has 5 entries; robot 'ur5' has nq = 6").
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from service.errors import DimensionMismatch, InvalidConfiguration, InvalidInput
from service.registry.robot import Robot
from service.state_numbers import (
    all_finite,
    batch_numbers,
    column_extremes,
    first_non_finite,
    unit_norms,
)

UNIT_NORM_TOL = 1e-6  # |‖quaternion‖ − 1| and |‖(cos, sin)‖ − 1| allowed in q

# Which dimension each joint-space input has (`waypoints`: configurations a path passes
# through, as retime takes them).
SPACES = {"q": "nq", "v": "nv", "a": "nv", "tau": "nv", "waypoints": "nq"}

_WXYZ = "quaternion (w, x, y, z)"  # a MuJoCo-qpos robot's (MJCF): `Robot.mujoco_qpos`
_UNIT_KIND = {
    "free_flyer": "quaternion (x, y, z, w)",
    "spherical": "quaternion (x, y, z, w)",
    "planar": "(cos θ, sin θ)",
    "continuous": "(cos θ, sin θ)",
}


@dataclass(frozen=True)
class States:
    """Validated joint-space inputs, each of shape (N, n), and whether the request was a batch;
    `first`: the index in the request of the first state (a chunk of a large batch, where
    errors name the request's state)."""

    arrays: dict[str, np.ndarray]
    batched: bool
    first: int = 0
    warnings: tuple[str, ...] = ()  # what is computed as given but likely a mistake

    @property
    def count(self) -> int:
        count: int = next(iter(self.arrays.values())).shape[0]
        return count

    def __getitem__(self, name: str) -> np.ndarray:
        return self.arrays[name]

    def unbatch(self, value: np.ndarray) -> np.ndarray:
        """Drop the leading batch axis of an answer when the request was a single state."""
        return value if self.batched else value[0]


def as_array(name: str, value: Any, what: str = "(one state) or 2-D (a batch)") -> np.ndarray:
    """`value` as a finite float64 array of 1 or 2 dimensions (`what` says what each means),
    or `InvalidInput` naming `name`: ragged lists, non-numbers, other ranks and NaN/inf are
    refused here, before any computation sees them."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (ValueError, TypeError):
        raise InvalidInput(
            f"{name} must be an array of numbers or an array of equal-length arrays of numbers"
        ) from None
    if arr.ndim not in (1, 2):
        raise InvalidInput(f"{name} must be 1-D {what}, not {arr.ndim}-D")
    if not all_finite(arr):
        raise _non_finite(name, arr)
    return arr


def _non_finite(name: str, arr: np.ndarray) -> InvalidInput:
    return InvalidInput(
        f"{name} contains a non-finite number (NaN or infinity): {first_non_finite(arr)}"
    )


def prepare(
    robot: Robot,
    inputs: Mapping[str, Any],
    max_batch: int,
    finite_later: frozenset[str] = frozenset(),
) -> States:
    """Check and convert the joint-space inputs named in `inputs` (keys of SPACES). A large
    batch's numbers are read on two threads at once (`state_numbers.batch_numbers`); the
    errors are the same, in the same order. `finite_later`: inputs (not q) whose finiteness a
    large batch leaves to the caller, who knows a non-finite one from its answer and then
    calls `prepare` again without it (see `service.dynamics.finite_from_answer`)."""
    unit_entries = [(start, end) for _, start, end in robot.unit_joints]
    numbers = batch_numbers(inputs, robot.nq, unit_entries, finite_later)
    if numbers is None:
        arrays = {name: as_array(name, value) for name, value in inputs.items()}
    else:
        arrays = dict(inputs)  # (float64 (N, n) arrays: as_array would return them as they are)
        for name, arr in arrays.items():
            if numbers.non_finite[name]:
                raise _non_finite(name, arr)
    ndims = {arr.ndim for arr in arrays.values()}
    if len(ndims) > 1:
        shapes = ", ".join(f"{n} is {a.ndim}-D" for n, a in arrays.items())
        raise DimensionMismatch(
            f"inputs mix single states and batches ({shapes}); give all as 1-D or all as 2-D arrays"
        )
    batched = ndims == {2}
    if batched:
        sizes = {n: a.shape[0] for n, a in arrays.items()}
        if len(set(sizes.values())) > 1:
            shown = ", ".join(f"{n} has {s}" for n, s in sizes.items())
            raise DimensionMismatch(
                f"batch sizes differ ({shown} states); every input needs the same number of states"
            )
        count = next(iter(sizes.values()))
        if count == 0:
            raise DimensionMismatch("the batch is empty; send at least one state")
        if count > max_batch:
            first = next(iter(sizes))
            raise DimensionMismatch(
                f"{first} has {count} rows (states); the limit is {max_batch} (ROBODYN_MAX_BATCH)"
            )
    else:
        arrays = {n: a[np.newaxis, :] for n, a in arrays.items()}
    for name, arr in arrays.items():
        dim_name = SPACES[name]
        expected = getattr(robot, dim_name)
        if arr.shape[1] != expected:
            what = "each state of " + name if batched else name
            raise DimensionMismatch(
                f"{what} has {arr.shape[1]} entries; robot '{robot.id}' has {dim_name} = "
                f"{expected}{_left_out(robot, dim_name, arr.shape[1])}"
            )
    warnings: tuple[str, ...] = ()
    if "q" in arrays:
        extremes = None if numbers is None else numbers.q_extremes
        far = angles_far_outside(robot, arrays["q"], extremes)
        warnings = (far,) if far else ()
        arrays["q"] = configurations(robot, arrays["q"], None if numbers is None else numbers.norms)
    return States(arrays=arrays, batched=batched, warnings=warnings)


_JOINTS_SHOWN = 4  # joints named in a dimension mismatch's hint, at most


def _left_out(robot: Robot, dim_name: str, given: int) -> str:
    """What a vector of `given` entries (fewer than `dim_name`) leaves out: the joints whose
    entries come after them, and the two ways to leave joints out on purpose. "" when `given`
    is not fewer, or ends inside a joint."""
    model = robot.model
    last = [
        (model.names[j], int(getattr(model.joints[j], f"idx_{dim_name[1]}")))
        for j in range(1, model.njoints)
        if getattr(model.joints[j], dim_name) > 0
    ]
    missing = [name for name, start in last if start >= given]
    if given >= getattr(robot, dim_name) or not missing or all(s != given for _, s in last):
        return ""
    shown = ", ".join(f"'{n}'" for n in missing[:_JOINTS_SHOWN])
    more = f" and {len(missing) - _JOINTS_SHOWN} more" if len(missing) > _JOINTS_SHOWN else ""
    return (
        f"; the entries of {len(missing)} joint(s) are missing ({shown}{more}, in model "
        'order): send them too, or key the vectors by joint name with "fill": "neutral" '
        "(the joints left out held at their neutral position and at rest), or store the "
        f'robot without them (POST /v1/robots/{robot.id}/reduce with "locked_joints")'
    )


def configurations(
    robot: Robot, q: np.ndarray, norms: Mapping[int, np.ndarray] | None = None
) -> np.ndarray:
    """Checked configurations (N, nq) as the API gives them, in Pinocchio's order: unit norms
    checked (`check_configuration`; `norms`: those already computed, by q start), then each
    quaternion of a MuJoCo-qpos robot (MJCF) turned from (w, x, y, z) into (x, y, z, w)
    (`Robot.pinocchio_q`). Every q of a request (the states, a PD target) passes here; other
    robots' q is returned as it is."""
    check_configuration(robot, q, norms)
    return q if robot.q_from_api is None else robot.pinocchio_q(q)


def angles_far_outside(
    robot: Robot, q: np.ndarray, extremes: tuple[np.ndarray, np.ndarray] | None = None
) -> str | None:
    """A warning when the angle of a revolute joint with a finite range lies a whole turn
    (2π rad) or more outside it in some state of q (the API's order), else None: most often
    an angle given in degrees. It may also be a state a simulation reached (limits are not
    enforced there), so it is computed as given, with the warning. `extremes`: q's columns'
    smallest and largest entries, when already computed."""
    names, index, lower, upper = robot.angle_ranges
    if not index.size:
        return None
    # Each joint's smallest and largest angle over the states first (no copy of q): a whole
    # turn outside is rare, and only then is the state looked for.
    smallest, largest = column_extremes(q) if extremes is None else extremes
    if not np.max(np.maximum(lower - smallest[index], largest[index] - upper)) >= 2 * np.pi:
        return None
    angles = q[:, index]
    beyond = np.maximum(lower - angles, angles - upper)
    state, joint = np.unravel_index(np.argmax(beyond), beyond.shape)
    if not beyond[state, joint] >= 2 * np.pi:
        return None
    value = float(angles[state, joint])
    where = f"state {int(state)}: " if q.shape[0] > 1 else ""
    return (
        f"{where}q[{int(index[joint])}] = {value:.6g} rad, the angle of revolute joint "
        f"'{names[joint]}', is {beyond[state, joint] / (2 * np.pi):.3g} turns outside its range "
        f"[{lower[joint]:.6g}, {upper[joint]:.6g}] rad; angles are in radians ({value:.6g} "
        f"degrees would be {np.radians(value):.6g} rad)"
    )


def check_configuration(
    robot: Robot, q: np.ndarray, computed: Mapping[int, np.ndarray] | None = None
) -> None:
    """Quaternions and (cos, sin) pairs in q (the API's order) must have unit norm (within
    UNIT_NORM_TOL; `computed`: norms already computed, by q start)."""
    for joint, start, end in robot.unit_joints:
        norms = computed.get(start) if computed else None
        if norms is None:
            norms = unit_norms(q, start, end)
        bad = np.flatnonzero(np.abs(norms - 1.0) > UNIT_NORM_TOL)
        if bad.size:
            i = int(bad[0])
            where = f"state {i}: " if q.shape[0] > 1 else ""
            kind = _UNIT_KIND.get(robot.joint_types[joint], "unit vector")
            if start in robot.wxyz_starts:
                kind = _WXYZ
            raise InvalidConfiguration(
                f"{where}q[{start}:{end}] is the {kind} of joint '{joint}' and must have unit "
                f"norm; its norm is {norms[i]:.9g}"
            )
