"""The answer budget: how big a dynamics answer will be, known before computing it.

An answer's size follows from the robot's dimensions, the request's options and the number of
states alone (never from the values): each quantity's `answer_size(robot, options, with_v)`
(`service.dynamics.Quantity`) counts the numbers of one state's answer, exactly as the quantity
shapes it (tests check each formula against computed answers). The answer is estimated at
`JSON_BYTES_PER_NUMBER` bytes per number in JSON (the longest text of a float64,
`-2.2250738585072014e-308`, and its comma) and `BINARY_BYTES_PER_NUMBER` in the binary form
(plus `key_bytes` with `"joint_names": true`, when the quantity has answers keyed by joint
name); one over `ROBODYN_MAX_ANSWER_BYTES` is
refused with 413 `payload_too_large` naming the largest batch that fits, before any work.
"""

from __future__ import annotations

from typing import Any

from service.dynamics import Quantity
from service.errors import PayloadTooLarge

JSON_BYTES_PER_NUMBER = 25
BINARY_BYTES_PER_NUMBER = 8


def check_answer_size(quantity: Quantity, robot: Any, options: dict[str, Any], with_v: bool,
                      states: int, bytes_per_number: int, limit: int) -> None:
    """Raise `PayloadTooLarge` when the answer of `states` states would exceed `limit` bytes,
    naming the largest batch that fits (or, where the quantity says, what else fits)."""
    numbers = quantity.answer_size(robot, options, with_v)
    size = numbers * states * bytes_per_number
    if size <= limit:
        return
    form = "binary" if bytes_per_number == BINARY_BYTES_PER_NUMBER else "JSON"
    fits = limit // (numbers * bytes_per_number)
    what = (f"the {quantity.name} answer of {states:,} state{'s' if states != 1 else ''} of robot "
            f"'{robot.id}' would be about {_megabytes(size)} in {form} ({numbers:,} numbers "
            f"a state), over the limit of {_megabytes(limit)} (ROBODYN_MAX_ANSWER_BYTES)")
    if fits >= 1:
        hint = f"send batches of at most {fits:,} states"
        if form == "JSON":
            binary_fits = limit // (numbers * BINARY_BYTES_PER_NUMBER)
            hint += f" ({binary_fits:,} with the binary form)"
    elif quantity.smaller_request is not None:
        hint = quantity.smaller_request(robot, limit // bytes_per_number)
    else:
        hint = "even one state's answer does not fit"
    raise PayloadTooLarge(f"{what}: {hint}", largest_batch=fits)


def key_bytes(robot: Any) -> int:
    """Bytes a number of an answer keyed by joint name may carry besides itself: the longest
    joint name, quoted, with its colon and brackets (counted for every number: an upper
    bound)."""
    return max((len(name.encode()) for name in robot.model.names), default=0) + 5


def _megabytes(size: int) -> str:
    return f"{size / 1e6:,.1f} MB"
