"""Request builders of the trajectory routes: the check of a sampled motion against the
robot's limits, and the time-optimal timing of a path through waypoints. (The clients'
docstrings describe them.) The rows of their inputs are one motion or one path: never sent in
chunks."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from robodyn._calls.request import request
from robodyn.arrays import ArrayLike
from robodyn.core import Call
from robodyn.errors import InputError
from robodyn.payloads import PayloadsLike
from robodyn.trajectories import (
    Retimed,
    TrajectoryCheck,
    acceleration_limits,
    positive,
    times,
)

BOUNDARIES = ("not-a-knot", "clamped", "natural")


def trajectory_check(
    robot_id: str,
    t: ArrayLike,
    q: ArrayLike,
    *,
    v: ArrayLike | None = None,
    a: ArrayLike | None = None,
    effort_scale: float = 1.0,
    velocity_scale: float = 1.0,
    acceleration: ArrayLike | None = None,
    boundary: str = "not-a-knot",
    samples_per_interval: int = 4,
    friction: bool = False,
    payloads: PayloadsLike | None = None,
) -> Call[TrajectoryCheck]:
    if (
        isinstance(samples_per_interval, bool)
        or not isinstance(samples_per_interval, int)
        or not 1 <= samples_per_interval <= 64
    ):
        raise InputError("samples_per_interval must be an integer from 1 to 64")
    if boundary not in BOUNDARIES:
        raise InputError(f"boundary must be one of {', '.join(BOUNDARIES)}, not {boundary!r}")
    sample_times = times(t)
    options: dict[str, Any] = {
        "limits": _limits(velocity_scale, effort_scale, acceleration),
        "boundary": boundary,
        "samples_per_interval": samples_per_interval,
    }
    if friction:
        options["friction"] = True
    call = request(
        robot_id,
        "trajectory-check",
        TrajectoryCheck.from_json,
        options,
        payloads=payloads,
        optional=("v", "a"),
        independent_rows=False,
        q=q,
        v=v,
        a=a,
    )
    # t is one number per sample, not a joint-space input: added after those are checked (a
    # list in JSON, a tensor in the binary form, where a header of 60,000 times would not fit)
    return replace(call, arrays={"t": sample_times, **(call.arrays or {})})


def retime(
    robot_id: str,
    waypoints: ArrayLike,
    *,
    velocity_scale: float = 1.0,
    effort_scale: float = 1.0,
    acceleration: ArrayLike | None = None,
    sample_dt: float = 0.01,
    payloads: PayloadsLike | None = None,
) -> Call[Retimed]:
    limits = _limits(velocity_scale, effort_scale, acceleration)
    options = {"limits": limits, "sample_dt": positive("sample_dt", sample_dt)}
    return request(
        robot_id,
        "retime",
        Retimed.from_json,
        options,
        payloads=payloads,
        independent_rows=False,
        waypoints=waypoints,
    )


def _limits(
    velocity_scale: float, effort_scale: float, acceleration: ArrayLike | None
) -> dict[str, Any]:
    """The request's `limits` object: the scales, and the acceleration limits where given
    (an entry None or NaN: no limit on that joint)."""
    limits: dict[str, Any] = {
        "velocity_scale": positive("velocity_scale", velocity_scale),
        "effort_scale": positive("effort_scale", effort_scale),
    }
    accelerations = acceleration_limits(acceleration)
    if accelerations is not None:
        limits["acceleration"] = accelerations
    return limits
