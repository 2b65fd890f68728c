"""What sizing a joint's motor and bearings needs from a motion, gathered chunk by chunk.

Per 1-DoF joint, over every evaluated point of a trajectory check (`JointLoadPeaks.add`, the
points in time order):

    rms_effort            √(∫ τ² dt ÷ duration)   N·m or N  (trapezoidal rule: motor heating)
    peak_power            max |τ v|               W
    peak_force            max ‖f‖                 N
    peak_moment           max ‖n‖                 N·m
    peak_axial_force      max |f · s|             N
    peak_bending_moment   max ‖n − (n · s) s‖     N·m

with (f, n) the wrench the joint transmits to its child body (RNEA's `data.f`, in the joint
frame) and s its unit axis (`service.dynamics.joint_loads`). τ and the wrench include the
friction torque where the check adds it (along s only).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from service.dynamics.joint_loads import add_friction, bearing_loads, joint_axes, rnea_with_wrenches
from service.errors import NonFiniteResult
from service.registry.robot import Robot

LOADS = ("force", "moment", "axial_force", "bending_moment")


def inverse_dynamics_with_loads(
    robot: Robot,
    q: np.ndarray,
    v: np.ndarray,
    a: np.ndarray,
    friction: Callable[[np.ndarray], np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(τ (n, nv), the wrenches of the 1-DoF joints (n, J, 6)) at n states (q in Pinocchio's
    order), by RNEA state by state; `friction(v)` (optional) adds its torque to τ and along
    each joint's axis to its wrench. Non-finite values are returned as they are (the caller
    checks τ)."""
    axes = joint_axes(robot)
    tau, wrenches = rnea_with_wrenches(robot, q, v, a, joints=axes.single)
    if friction is not None:
        with np.errstate(over="ignore", invalid="ignore"):
            torque = friction(v)
            tau = tau + torque
            wrenches = add_friction(robot, wrenches, torque, axes.single)
    return tau, wrenches


class JointLoadPeaks:
    """RMS effort, peak power and peak loads of the 1-DoF joints (model order) of a motion
    whose evaluated points come in consecutive chunks (`add`); `figures()` at the end. Time is
    counted in `unit` (s: the largest sample interval), so that neither ∫ τ² dt nor the
    duration overflows for samples however far apart."""

    def __init__(self, robot: Robot, unit: float = 1.0) -> None:
        self.unit = unit
        axes = joint_axes(robot)
        self.axes = axes.axes
        self.iv = np.array([axes.v_index[j] for j in axes.single], dtype=int)
        count = self.iv.size
        self.effort_squared = np.zeros(count)  # ∫ τ² dt so far, in N²·m² × unit
        self.duration = 0.0  # in unit
        self.peak_power = np.zeros(count)
        self.peaks = {name: np.zeros(count) for name in LOADS}
        self._last: tuple[float, np.ndarray] | None = None  # (t, τ²) of the last point so far

    def add(self, t: np.ndarray, v: np.ndarray, tau: np.ndarray, wrenches: np.ndarray) -> None:
        """The next evaluated points: times t [n] (s), v and τ [n, nv], the 1-DoF joints'
        wrenches [n, J, 6]."""
        with np.errstate(over="ignore", invalid="ignore"):
            effort, speed = tau[:, self.iv], v[:, self.iv]
            np.maximum(self.peak_power, np.abs(effort * speed).max(axis=0), out=self.peak_power)
            for name, value in bearing_loads(wrenches, self.axes).items():
                np.maximum(self.peaks[name], value.max(axis=0), out=self.peaks[name])
            squared = effort**2
            if self._last is not None:
                t = np.concatenate([[self._last[0]], t])
                squared = np.concatenate([self._last[1][None], squared])
            steps = np.diff(t) / self.unit
            self.effort_squared += steps @ (0.5 * (squared[1:] + squared[:-1]))
            self.duration += float(steps.sum())
        self._last = (float(t[-1]), squared[-1])

    def figures(self) -> list[dict[str, float]]:
        """Per 1-DoF joint: rms_effort, peak_power and the four peak loads; NonFiniteResult
        when one overflows float64."""
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            rms = np.sqrt(self.effort_squared / self.duration)
        columns: dict[str, Any] = {
            "rms_effort": rms,
            "peak_power": self.peak_power,
            **{f"peak_{name}": value for name, value in self.peaks.items()},
        }
        for name, value in columns.items():
            if not np.isfinite(value).all():
                raise NonFiniteResult(
                    f"trajectory-check: the joints' {name} overflows float64 for this motion "
                    "(its torques, velocities or loads are too large to compute with)"
                )
        return [
            {name: float(value[j]) for name, value in columns.items()} for j in range(self.iv.size)
        ]
