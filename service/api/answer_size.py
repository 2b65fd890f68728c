"""The answer budget: how big a dynamics answer will be, known before computing it.

An answer's size follows from the robot's dimensions, the request's options and the number of
states alone (never from the values): `NUMBERS_PER_STATE[quantity](robot, options, with_v)`
counts the numbers of one state's answer, exactly as the quantity shapes it (tests check each
formula against computed answers). The answer is estimated at `JSON_BYTES_PER_NUMBER` bytes
per number in JSON (the longest text of a float64, `-2.2250738585072014e-308`, and its comma)
and `BINARY_BYTES_PER_NUMBER` in the binary form (plus `key_bytes` with `"joint_names": true`,
when the quantity has answers keyed by joint name); one over `ROBODYN_MAX_ANSWER_BYTES` is
refused with 413 `payload_too_large` naming the largest batch that fits, before any work.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from service.dynamics.placements import body_frames
from service.errors import PayloadTooLarge

JSON_BYTES_PER_NUMBER = 25
BINARY_BYTES_PER_NUMBER = 8

# (robot, options, v given) -> numbers in the answer of one state
PerState = Callable[[Any, dict[str, Any], bool], int]


def _task_rows(options: dict[str, Any]) -> int:
    """Rows k of an operational-space task: 6 for "full", 3 for "linear" or "angular"."""
    return 6 if options.get("task", "full") == "full" else 3


def _operational_space(robot: Any, options: dict[str, Any], v: bool) -> int:
    k = _task_rows(options)  # Λ (k, k), J (k, nv), J̄ (nv, k), p (k), with v μ (k)
    return k * k + 2 * k * robot.nv + k + (k if v else 0)


def _simulate(robot: Any, options: dict[str, Any], v: bool) -> int:
    samples = int(options.get("steps", 1)) + 1  # t, q, v and the energy at every sample
    drift = 1 if options.get("contacts") else 0  # and the constraint drift with contacts
    return samples * (robot.nq + robot.nv + 2 + drift)


def _contact_size(options: dict[str, Any]) -> int:
    """m, the numbers of a contact force vector: 3 per point contact, 6 per 6d contact."""
    return sum(3 if c.get("type", "point") == "point" else 6 for c in options.get("contacts", ()))


def _frame_placements(robot: Any, options: dict[str, Any], v: bool) -> int:
    frames = options.get("frames")  # a position (3) and a rotation (3×3) per frame
    count = len(body_frames(robot)[0]) if frames is None else len(frames)
    return 12 * count


NUMBERS_PER_STATE: dict[str, PerState] = {
    "mass-matrix": lambda r, o, v: r.nv * r.nv,
    "mass-matrix-inverse": lambda r, o, v: r.nv * r.nv,
    "gravity": lambda r, o, v: r.nv,
    "nonlinear-effects": lambda r, o, v: r.nv,
    "inverse-dynamics": lambda r, o, v: r.nv,
    "forward-dynamics": lambda r, o, v: r.nv,
    "coriolis": lambda r, o, v: r.nv * r.nv + r.nv,
    "energy": lambda r, o, v: 3,
    "center-of-mass": lambda r, o, v: 3 + 3 * r.nv + (3 if v else 0),
    "jacobian": lambda r, o, v: 6 * r.nv * (2 if v else 1),
    "operational-space": _operational_space,
    "centroidal": lambda r, o, v: 6 + 6 * r.nv + 3,
    "inverse-dynamics-derivatives": lambda r, o, v: 3 * r.nv * r.nv,
    "forward-dynamics-derivatives": lambda r, o, v: 3 * r.nv * r.nv,
    "simulate": _simulate,
    "contact-dynamics": lambda r, o, v: r.nv + _contact_size(o),
    "contact-inverse-dynamics": lambda r, o, v: r.nv + _contact_size(o) + 1,
    "impulse-dynamics": lambda r, o, v: r.nv + _contact_size(o),
    "frame-placements": _frame_placements,
}


def check_answer_size(quantity: str, robot: Any, options: dict[str, Any], with_v: bool,
                      states: int, bytes_per_number: int, limit: int) -> None:
    """Raise `PayloadTooLarge` when the answer of `states` states would exceed `limit` bytes,
    naming the largest batch that fits. Quantities without a formula are not checked."""
    per_state = NUMBERS_PER_STATE.get(quantity)
    if per_state is None:
        return
    numbers = per_state(robot, options, with_v)
    size = numbers * states * bytes_per_number
    if size <= limit:
        return
    form = "binary" if bytes_per_number == BINARY_BYTES_PER_NUMBER else "JSON"
    fits = limit // (numbers * bytes_per_number)
    what = (f"the {quantity} answer of {states:,} state{'s' if states != 1 else ''} of robot "
            f"'{robot.id}' would be about {_megabytes(size)} in {form} ({numbers:,} numbers "
            f"a state), over the limit of {_megabytes(limit)} (ROBODYN_MAX_ANSWER_BYTES)")
    if fits >= 1:
        hint = f"send batches of at most {fits:,} states"
        if form == "JSON":
            binary_fits = limit // (numbers * BINARY_BYTES_PER_NUMBER)
            hint += f" ({binary_fits:,} with the binary form)"
    elif quantity == "simulate":
        per_step = robot.nq + robot.nv + 2
        steps = limit // (per_step * bytes_per_number) - 1
        hint = f"simulate at most {max(steps, 0):,} steps per request"
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
