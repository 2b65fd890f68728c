"""The answer budget: how big a dynamics answer will be, known before computing it.

An answer's size follows from the robot's dimensions, the request's options and the number of
states alone (never from the values): each quantity's `answer_size(robot, options, with_v)`
(`service.dynamics.Quantity`) counts the numbers of one state's answer, exactly as the quantity
shapes it (tests check each formula against computed answers). `answer_bytes` turns it into
the bytes that will really be sent, as an upper bound:

- JSON: `JSON_BYTES_PER_NUMBER` bytes per number (the longest text of a float64,
  `-2.2250738585072014e-308`, and its comma), and with `"joint_names": true` each number of
  a keyed answer also carries its key (`key_bytes`);
- the binary form: `BINARY_BYTES_PER_NUMBER` (float64) per number, exactly, whatever
  `"joint_names"` says (the joint-space answers stay tensors, and the joint names are given
  once, in `__metadata__`: `joint_layout_bytes`);
- and, in both forms, `ANSWER_ALLOWANCE` bytes for what is not a number (member names,
  brackets, the binary header) plus the robot's frame names (frame-placements answers them).

An answer over `ROBODYN_MAX_ANSWER_BYTES` is refused with 413 `payload_too_large` naming the
largest batch that fits, before any work.
"""

from __future__ import annotations

from typing import Any

from service.dynamics import Quantity
from service.errors import PayloadTooLarge

JSON_BYTES_PER_NUMBER = 25
BINARY_BYTES_PER_NUMBER = 8
ANSWER_ALLOWANCE = 4096
"""Bytes of an answer that are not its numbers, at most, besides names: member names and
brackets of small answers, the binary header's tensor entries."""


def answer_bytes(
    quantity: Quantity,
    robot: Any,
    options: dict[str, Any],
    with_v: bool,
    states: int,
    binary: bool = False,
    named: bool = False,
) -> int:
    """An upper bound of the bytes of the answer of `states` states (see the module)."""
    per_state, fixed = _bytes(quantity, robot, options, with_v, binary, named)
    return per_state * states + fixed


def _bytes(
    quantity: Quantity, robot: Any, options: dict[str, Any], with_v: bool, binary: bool, named: bool
) -> tuple[int, int]:
    """(bytes of one state's answer, bytes of the answer besides its states)."""
    numbers = quantity.answer_size(robot, options, with_v)
    keyed = named and bool(quantity.joint_answers)
    fixed = ANSWER_ALLOWANCE + frame_names_bytes(robot)
    if binary:
        if keyed:
            fixed += len(quantity.joint_answers) * joint_layout_bytes(robot)
        return numbers * BINARY_BYTES_PER_NUMBER, fixed
    per_number = JSON_BYTES_PER_NUMBER + (key_bytes(robot) if keyed else 0)
    return numbers * per_number, fixed


def check_answer_size(
    quantity: Quantity,
    robot: Any,
    options: dict[str, Any],
    with_v: bool,
    states: int,
    limit: int,
    binary: bool = False,
    named: bool = False,
) -> int:
    """The answer's size in bytes (`answer_bytes`); `PayloadTooLarge` when it would exceed
    `limit` bytes, naming the largest batch that fits (or, where the quantity says, what else
    fits)."""
    per_state, fixed = _bytes(quantity, robot, options, with_v, binary, named)
    size = per_state * states + fixed
    if size <= limit:
        return size
    numbers = quantity.answer_size(robot, options, with_v)
    form = "binary" if binary else "JSON"
    fits = max(limit - fixed, 0) // max(per_state, 1)
    what = (
        f"the {quantity.name} answer of {states:,} state{'s' if states != 1 else ''} of robot "
        f"'{robot.id}' would be about {_megabytes(size)} in {form} ({numbers:,} numbers "
        f"a state), over the limit of {_megabytes(limit)} (ROBODYN_MAX_ANSWER_BYTES)"
    )
    if fits >= 1:
        hint = f"send batches of at most {fits:,} states"
        if not binary:
            binary_state, binary_fixed = _bytes(quantity, robot, options, with_v, True, named)
            binary_fits = max(limit - binary_fixed, 0) // max(binary_state, 1)
            hint += f" ({binary_fits:,} with the binary form)"
    elif quantity.smaller_request is not None:
        per_number = per_state // max(numbers, 1)
        hint = quantity.smaller_request(robot, max(limit - fixed, 0) // max(per_number, 1))
    else:
        hint = "even one state's answer does not fit"
    raise PayloadTooLarge(f"{what}: {hint}", largest_batch=fits)


def key_bytes(robot: Any) -> int:
    """Bytes a number of an answer keyed by joint name may carry besides itself: the longest
    joint name, quoted, with its colon and brackets (counted for every number: an upper
    bound)."""
    return max((len(name.encode()) for name in robot.model.names), default=0) + 5


def joint_layout_bytes(robot: Any) -> int:
    """An upper bound of the bytes of one answer's joint layout in the binary form's
    `__metadata__` (`["name", start, size]` per joint, as JSON text inside a JSON string:
    every quote escaped)."""
    return sum(2 * len(name.encode()) + 40 for name in robot.model.names)


def frame_names_bytes(robot: Any) -> int:
    """An upper bound of the bytes of the robot's frame names in an answer (quoted, with a
    comma, escaped once more in the binary form's metadata)."""
    return sum(2 * len(name.encode()) + 6 for name in robot.frame_names)


def _megabytes(size: int) -> str:
    return f"{size / 1e6:,.1f} MB"
