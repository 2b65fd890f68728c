"""External wrenches at named frames, as the per-joint forces Pinocchio's RNEA and ABA take.

A request gives a list of `{"frame", "wrench": [fx, fy, fz, tx, ty, tz], "reference_frame"}`:
a wrench (N, N·m) that the environment applies to the body carrying `frame`. With J the frame
Jacobian in the same reference frame, it adds Jᵀ w to the generalized forces:

    τ = M(q) a + C(q, v) v + g(q) − Σ Jᵀ w      (inverse dynamics)
    a = M(q)⁻¹ (τ − C(q, v) v − g(q) + Σ Jᵀ w)  (forward dynamics)

Reference frames, as in Pinocchio:
- "local_world_aligned" (default): force and torque about the frame's origin, world axes;
- "local": force and torque about the frame's origin, in the frame's own axes;
- "world": force and torque about the world origin, world axes (Pinocchio's spatial force
  in the world frame; a pure force f at the frame's origin p has torque p × f there).

Each wrench is converted to the local frame of the frame's parent joint (`pin.Force`), and the
wrenches on one joint are summed into `fext[joint]`. A wrench is either 6 numbers (the same for
every state of a batch) or [N][6] (one per state).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from service.dynamics.frames import frame_id
from service.errors import DimensionMismatch
from service.registry.robot import Robot
from service.states import States

DEFAULT_REFERENCE_FRAME = "local_world_aligned"


@dataclass(frozen=True)
class _Wrench:
    joint: int  # parent joint of the frame
    placement: Any  # pin.SE3: the frame in its parent joint's frame (jMf)
    values: np.ndarray  # (6,) or (N, 6): linear then angular
    reference_frame: str


class ExternalForces:
    """The wrenches of one request, checked against the robot and the batch."""

    def __init__(self, robot: Robot, forces: Sequence[Mapping[str, Any]], s: States) -> None:
        self.model = robot.model
        self.wrenches: list[_Wrench] = []
        for k, force in enumerate(forces):
            fid = frame_id(robot, force["frame"], f"external_forces[{k}].frame")
            frame = self.model.frames[fid]
            values = np.asarray(force["wrench"], dtype=np.float64)
            if values.ndim == 2 and (not s.batched or values.shape[0] != s.count):
                expected = f"{s.count} states" if s.batched else "one state"
                raise DimensionMismatch(
                    f"external_forces[{k}].wrench has {values.shape[0]} rows but the request "
                    f"has {expected}; give 6 numbers (one wrench for every state) or one "
                    "row per state"
                )
            self.wrenches.append(
                _Wrench(
                    int(frame.parentJoint),
                    frame.placement,
                    values,
                    force.get("reference_frame", DEFAULT_REFERENCE_FRAME),
                )
            )
        self.needs_kinematics = any(w.reference_frame != "local" for w in self.wrenches)
        self._joints = sorted({w.joint for w in self.wrenches})
        self._fext = pin.StdVec_Force()  # reused from state to state (RNEA/ABA only read it)
        self._fext.extend(pin.Force.Zero() for _ in range(self.model.njoints))

    def at(self, data: Any, q: np.ndarray, i: int) -> Any:
        """`fext` (pin.StdVec_Force, one force per joint, in the joint's local frame) for state
        i at configuration q, valid until the next call. Uses (and overwrites) `data`'s
        placements."""
        if self.needs_kinematics:
            pin.forwardKinematics(self.model, data, q)
        fext = self._fext
        for joint in self._joints:
            fext[joint] = pin.Force.Zero()
        for w in self.wrenches:
            values = w.values[i] if w.values.ndim == 2 else w.values
            force = pin.Force(values[:3], values[3:])
            if w.reference_frame == "local":
                local = w.placement.act(force)
            else:
                oMi = data.oMi[w.joint]
                if w.reference_frame == "local_world_aligned":
                    origin = (oMi * w.placement).translation
                    force = pin.SE3(np.eye(3), origin).act(force)
                local = oMi.actInv(force)
            fext[w.joint] = fext[w.joint] + local
        return fext
