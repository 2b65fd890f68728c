"""The limited quantities along a path, sampled on the verification grid, and how far a timing
takes each of them relative to its limit.

The verification grid puts V + 1 evenly spaced points θ = 0, 1/V, …, 1 in every TOPP-RA
interval; the solver's m + 1 points per interval are every (V/m)-th of them, so the solver's
rows and the verification read the same numbers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from service.dynamics.trajectories import rnea
from service.dynamics.trajectories.constraints import Family
from service.dynamics.trajectories.envelope import lower_envelope, upper_envelope
from service.dynamics.trajectories.limits import JointLimit
from service.dynamics.trajectories.path import WaypointPath
from service.dynamics.trajectories.profile import Profile
from service.errors import InvalidInput
from service.registry.robot import Robot


@dataclass(frozen=True)
class PathSamples:
    """The path on the verification grid: points s, q, q', q'' and the torque coefficients
    A, B, C (`rnea.path_coefficients`), each (N, V + 1, n) (s: (N, V + 1)); θ [V + 1]."""

    theta: np.ndarray
    s: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray


def sample_path(
    robot: Robot, path: WaypointPath, gridpoints: np.ndarray, points: int
) -> PathSamples:
    """Evaluate the path at `points` + 1 evenly spaced points of every interval of
    `gridpoints` (the points shared by neighbouring intervals computed once)."""
    theta = np.linspace(0.0, 1.0, points + 1)
    n = len(gridpoints) - 1
    inner = gridpoints[:-1, None] + theta[None, :-1] * np.diff(gridpoints)[:, None]
    flat = np.concatenate([inner.reshape(-1), gridpoints[-1:]])
    q, dq, ddq = path(flat), path(flat, 1), path(flat, 2)
    A, B, C = rnea.path_coefficients(robot, q, dq, ddq)
    index = np.arange(n)[:, None] * points + np.arange(points + 1)[None, :]
    return PathSamples(
        theta, flat[index], q[index], dq[index], ddq[index], A[index], B[index], C[index]
    )


def families(samples: PathSamples, limits: list[JointLimit]) -> list[Family]:
    """The velocity, acceleration and effort families of the joints that have those limits."""
    out = []
    zero = np.zeros_like(samples.dq)
    moving = [lim for lim in limits if lim.velocity is not None]
    if moving:
        iv = [lim.iv for lim in moving]
        out.append(
            Family(
                "velocity",
                [lim.name for lim in moving],
                zero[..., iv],
                samples.dq[..., iv] ** 2,
                zero[..., iv],
                np.array([lim.velocity for lim in moving]) ** 2,
                None,
            )
        )
    quick = [lim for lim in limits if lim.acceleration is not None]
    if quick:
        iv = [lim.iv for lim in quick]
        acceleration = np.array([lim.acceleration for lim in quick])
        out.append(
            Family(
                "acceleration",
                [lim.name for lim in quick],
                samples.dq[..., iv],
                samples.ddq[..., iv],
                zero[..., iv],
                acceleration,
                -acceleration,
            )
        )
    strong = [lim for lim in limits if lim.effort is not None]
    if strong:
        iv = [lim.iv for lim in strong]
        effort = np.array([lim.effort for lim in strong])
        out.append(
            Family(
                "effort",
                [lim.name for lim in strong],
                samples.A[..., iv],
                samples.B[..., iv],
                samples.C[..., iv],
                effort,
                -effort,
            )
        )
    for family in out:
        _require_representable(family)
    return out


LIMIT_FIELDS = {  # the request's field that sets each family's limits
    "velocity": "limits.velocity_scale",
    "acceleration": "limits.acceleration",
    "effort": "limits.effort_scale",
}


def _require_representable(family: Family) -> None:
    """InvalidInput naming the limit when a family's limit is not a positive finite float64
    (a velocity limit whose square underflows or overflows) or the path's quantity over it
    overflows."""
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        ok = (family.upper > 0.0) & np.isfinite(family.upper)
        for part in (family.A, family.B, family.C):
            ok &= np.isfinite(part / family.upper).all(axis=(0, 1))
    if ok.all():
        return
    j = int(np.flatnonzero(~ok)[0])
    limit = float(np.sqrt(family.upper[j]) if family.kind == "velocity" else family.upper[j])
    raise InvalidInput(
        f"{LIMIT_FIELDS[family.kind]} gives joint '{family.joints[j]}' a {family.kind} limit "
        f"of {limit:.3g}: too small or too large to compute with (the path's {family.kind} "
        "over it is not a finite float64 number)"
    )


def subsample(family: Family, every: int) -> Family:
    """The family on every `every`-th point of each interval (the solver's points)."""
    pick = slice(None, None, every)
    return Family(
        family.kind,
        family.joints,
        family.A[:, pick],
        family.B[:, pick],
        family.C[:, pick],
        family.upper,
        family.lower,
    )


def interval_ratios(family: Family, profile: Profile, theta: np.ndarray) -> np.ndarray:
    """The estimated largest value of the family's quantity over each interval of the timed
    path (its envelope there, `envelope`), divided by its limit: (N, J); for velocity in
    squared units (q̇² / v_max²)."""
    _, x, u = profile.on_intervals(theta)
    f = family.values(x, u)
    worst = upper_envelope(f) / family.upper
    if family.lower is not None:
        worst = np.maximum(worst, lower_envelope(f) / family.lower)
    ratio: np.ndarray = worst
    return ratio


def ratios(family: Family, profile: Profile, theta: np.ndarray) -> np.ndarray:
    """The largest of `interval_ratios` over the whole path, per joint [J]."""
    ratio: np.ndarray = interval_ratios(family, profile, theta).max(axis=0)
    return ratio


def slowdown(family: Family, profile: Profile, theta: np.ndarray, target: float) -> np.ndarray:
    """Per joint, the time-scaling factor λ ≥ 1 that brings the family within `target` × its
    limit everywhere: f = D + C with D = A u + B x scaling as 1/λ² (`Profile.slowed`), so
    D/λ² + C + margin ≤ target·limit needs λ² ≥ D / (target·limit − C − margin) where D > 0
    (the curvature margin kept at its unscaled size, which only overestimates). inf where the
    constant part C (gravity) alone leaves no room."""
    _, x, u = profile.on_intervals(theta)
    D = family.values(x, u) - family.C
    margin = upper_envelope(D)[:, None, :] - D.max(axis=1)[:, None, :]  # curvature, ≥ 0
    need = np.ones(len(family.joints))
    for sign, bound in (
        (1.0, family.upper),
        (-1.0, None if family.lower is None else -family.lower),
    ):
        if bound is None:
            continue
        room = target * bound - sign * family.C - margin
        drive = sign * D
        with np.errstate(divide="ignore", invalid="ignore"):
            lam2 = np.where(drive > 0, np.where(room > 0, drive / room, np.inf), 1.0)
        need = np.maximum(need, np.sqrt(lam2.max(axis=(0, 1))))
    return need
