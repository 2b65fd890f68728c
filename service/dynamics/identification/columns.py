"""What is identified, as regressor columns: the whole robot, or a payload at a frame.

`Columns` gives, for states (q, v, a), the columns (n, nv, m) whose parameters θ (m,) are
unknown, and the torques (n, nv) that are known:

- the robot: [Y(q, v, a) | F(v)] with θ = [π; φ] (every body, then friction), known torques
  armature ∘ a;
- a payload held at a frame of body j: [Y_j(q, v, a) T | F(v)] with θ = [π_payload; φ], where
  Y_j are the 10 columns of body j, T maps parameters about the frame (origin and axes) to the
  joint frame (`parameters.transform_parameters`), and the known torques are the model's own
  inverse dynamics Y π₀ + armature ∘ a (everything but the payload and friction is fixed).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from service.dynamics.identification.parameters import (
    LAYOUT,
    PER_BODY,
    inertial_parameters,
    parameter_names,
    transform_parameters,
)
from service.dynamics.identification.regressor import (
    friction_columns,
    friction_names,
    joint_torque_regressor,
)
from service.errors import UnknownFrame, did_you_mean
from service.registry.robot import Robot

SAMPLE_CHUNK = 2048  # states per regressor chunk: bounds the memory of the full-width columns


@dataclass
class Columns:
    robot: Robot
    friction: str
    payload_frame: str | None = None
    names: list[str] = field(init=False)
    theta0: np.ndarray = field(init=False)  # the prior: the model's values, no friction
    bodies: int = field(init=False)  # leading blocks of 10 in θ that are bodies
    _pi0: np.ndarray = field(init=False)
    _transform: np.ndarray | None = field(init=False, default=None)
    _body: int = field(init=False, default=0)

    def __post_init__(self) -> None:
        model = self.robot.model
        joints = [str(model.names[j]) for j in range(1, model.njoints)]
        friction = friction_names(joints, self.friction)
        self._pi0 = inertial_parameters(model)
        if self.payload_frame is None:
            self.names = parameter_names(model) + friction
            self.theta0 = np.concatenate([self._pi0, np.zeros(len(friction))])
            self.bodies = model.njoints - 1
            return
        fid = self.robot.frame_ids.get(self.payload_frame)
        if fid is None:
            raise UnknownFrame(
                f"frame '{self.payload_frame}' is not a frame of robot "
                f"'{self.robot.id}'"
                f"{did_you_mean(self.payload_frame, self.robot.frame_ids)}"
            )
        frame = model.frames[fid]
        if frame.parentJoint == 0:
            raise UnknownFrame(
                f"frame '{self.payload_frame}' is fixed to the world: a payload "
                "there moves no joint and cannot be identified"
            )
        self._body = int(frame.parentJoint)
        self._transform = transform_parameters(frame.placement)
        self.names = [f"payload.{name}" for name in LAYOUT] + friction
        self.theta0 = np.zeros(PER_BODY + len(friction))
        self.bodies = 1

    @property
    def inertial_count(self) -> int:
        return PER_BODY * self.bodies

    def __call__(
        self, q: np.ndarray, v: np.ndarray, a: np.ndarray, select: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(columns (n, nv, m or len(select)), known torques (n, nv)) for states q (n, nq)
        in Pinocchio's order, v, a (n, nv)."""
        count = q.shape[0]
        width = len(self.names) if select is None else len(select)
        out = np.empty((count, self.robot.nv, width))
        known = a * np.asarray(self.robot.model.armature)[np.newaxis, :]
        with self.robot.data() as data:
            for start in range(0, count, SAMPLE_CHUNK):
                part = slice(start, min(start + SAMPLE_CHUNK, count))
                y = joint_torque_regressor(self.robot.model, data, q[part], v[part], a[part])
                if self._transform is not None:
                    known[part] += y @ self._pi0
                    body = slice(PER_BODY * (self._body - 1), PER_BODY * self._body)
                    y = y[:, :, body] @ self._transform
                full = np.concatenate([y, friction_columns(v[part], self.friction)], axis=2)
                out[part] = full if select is None else full[:, :, select]
        return out, known

    def robot_parameters(self, theta: np.ndarray) -> np.ndarray:
        """The robot's π (10 · bodies,) for fitted θ: θ's own, or for a payload the model's
        with the payload added to the body that carries its frame."""
        if self._transform is None:
            return theta[: self.inertial_count].copy()
        out = self._pi0.copy()
        out[PER_BODY * (self._body - 1) : PER_BODY * self._body] += (
            self._transform @ theta[:PER_BODY]
        )
        return out
