"""Client methods of identification: the inertial parameters, the regressor and identify
(`Client` and `AsyncClient` inherit them)."""

from __future__ import annotations

import numpy as np

from robodyn import progress as _progress
from robodyn._calls import identification as calls
from robodyn._calls.identification import Friction, Method
from robodyn._client import AsyncSender, SyncSender
from robodyn.arrays import ArrayLike
from robodyn.identification import Identification, InertialParameters


class IdentificationMethods(SyncSender):
    """The identification methods of `Client`."""

    def inertial_parameters(self, robot_id: str) -> InertialParameters:
        """The inertial parameters π of every body: an `InertialParameters` with `parameters`
        (10 · bodies,), each body's [m, m cx, m cy, m cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] in its
        joint's frame (kg, kg·m, kg·m²; the inertia about the joint origin), `bodies` (joint
        names, joint order) and `layout` (the 10 names). τ = `regressor(...)` @ π + armature ∘ a.
        Raises `RobotNotFoundError` for an unknown id.
        """
        return self._send(calls.inertial_parameters(robot_id))

    def regressor(self, robot_id: str, q: ArrayLike, v: ArrayLike, a: ArrayLike) -> np.ndarray:
        """The joint torque regressor Y(q, v, a) (Pinocchio's computeJointTorqueRegressor), linear
        in the inertial parameters: τ = Y π + armature ∘ a with π from `inertial_parameters`.
        Shape (nv, 10 · bodies), or (N, nv, 10 · bodies) for a batch of N states; entries in the
        units that make Y π N·m (N for prismatic rows).
        """
        return self._send(calls.regressor(robot_id, q, v, a))

    def identify(
        self,
        robot_id: str,
        t: ArrayLike,
        q: ArrayLike,
        tau: ArrayLike,
        *,
        v: ArrayLike | None = None,
        a: ArrayLike | None = None,
        friction: Friction = "coulomb-viscous",
        method: Method = "physically-consistent",
        weighted: bool = True,
        validation_fraction: float = 0.2,
        filter_hz: float | None = None,
        store: bool = True,
        payload_frame: str | None = None,
        include_series: bool = False,
        progress: _progress.Progress = None,
    ) -> Identification:
        """Identify a fixed-base robot's inertial parameters and friction from a logged motion,
        and (with `store`, the default) store the identified robot as a variant.

        `t` (N,) sample times in s, strictly increasing (irregular sampling is fine); `q`
        (N, nq) and the measured joint torques `tau` (N, nv), N·m or N — numpy arrays or any
        columns numpy can read (a pandas DataFrame's `.to_numpy()`, lists). `v`, `a` (N, nv)
        optional: when absent they come from q by zero-phase low-pass filtering at `filter_hz`
        (default 10 Hz, or a fifth of the sample rate when lower) and differentiation.
        `friction` per joint: "coulomb-viscous" (offset + Coulomb sign(v) + viscous v, the
        default), "viscous" or "none" (the offset alone). `method`: "physically-consistent"
        (every body's pseudo-inertia positive semidefinite, a semidefinite program regularized
        toward the model's values; the default) or "least-squares" (`weighted` False: ordinary).
        The last `validation_fraction` of the log (by time) is held out and predicted.
        `payload_frame`: identify only a payload held at that frame (the answer's `payload` is a
        `Payload`). `include_series`: also answer the measured and predicted torques on the
        held-out part.

        Returns an `Identification`: `parameters`, `bodies`, `friction`, `base_parameters`
        (expressions, values, standard deviations), `condition_number`,
        `physically_consistent`, `rmse` (train, validation, validation_before per joint) and
        `robot`/`robot_id` of the stored variant. The fit runs on the server in a worker process
        with a time limit (several seconds for tens of thousands of samples). Raises
        `UnsupportedModelError` for a free-flyer or planar base, `ValidationError` for a log it
        cannot identify from (non-increasing t, too few samples — the detail says how many are
        needed —, a motion that reveals too little), `DimensionMismatchError` for wrong widths.
        `progress`: a callable (done, total) or True for a tqdm bar (the client's by default):
        the server streams the fit's stages as they start, once the log is checked (base
        parameters, regressor, fit, validation: done 1 to 4 of 5; `robodyn.progress`).
        """
        return self._send(
            calls.identify(
                robot_id,
                t,
                q,
                tau,
                v=v,
                a=a,
                friction=friction,
                method=method,
                weighted=weighted,
                validation_fraction=validation_fraction,
                filter_hz=filter_hz,
                store=store,
                payload_frame=payload_frame,
                include_series=include_series,
            ),
            progress,
        )


class AsyncIdentificationMethods(AsyncSender):
    """The identification methods of `AsyncClient`."""

    async def inertial_parameters(self, robot_id: str) -> InertialParameters:
        """The inertial parameters π of every body: an `InertialParameters` with `parameters`
        (10 · bodies,), each body's [m, m cx, m cy, m cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] in its
        joint's frame (kg, kg·m, kg·m²; the inertia about the joint origin), `bodies` (joint
        names, joint order) and `layout` (the 10 names). τ = `regressor(...)` @ π + armature ∘ a.
        Raises `RobotNotFoundError` for an unknown id.
        """
        return await self._send(calls.inertial_parameters(robot_id))

    async def regressor(
        self, robot_id: str, q: ArrayLike, v: ArrayLike, a: ArrayLike
    ) -> np.ndarray:
        """The joint torque regressor Y(q, v, a) (Pinocchio's computeJointTorqueRegressor), linear
        in the inertial parameters: τ = Y π + armature ∘ a with π from `inertial_parameters`.
        Shape (nv, 10 · bodies), or (N, nv, 10 · bodies) for a batch of N states; entries in the
        units that make Y π N·m (N for prismatic rows).
        """
        return await self._send(calls.regressor(robot_id, q, v, a))

    async def identify(
        self,
        robot_id: str,
        t: ArrayLike,
        q: ArrayLike,
        tau: ArrayLike,
        *,
        v: ArrayLike | None = None,
        a: ArrayLike | None = None,
        friction: Friction = "coulomb-viscous",
        method: Method = "physically-consistent",
        weighted: bool = True,
        validation_fraction: float = 0.2,
        filter_hz: float | None = None,
        store: bool = True,
        payload_frame: str | None = None,
        include_series: bool = False,
        progress: _progress.Progress = None,
    ) -> Identification:
        """Identify a fixed-base robot's inertial parameters and friction from a logged motion,
        and (with `store`, the default) store the identified robot as a variant.

        `t` (N,) sample times in s, strictly increasing (irregular sampling is fine); `q`
        (N, nq) and the measured joint torques `tau` (N, nv), N·m or N — numpy arrays or any
        columns numpy can read (a pandas DataFrame's `.to_numpy()`, lists). `v`, `a` (N, nv)
        optional: when absent they come from q by zero-phase low-pass filtering at `filter_hz`
        (default 10 Hz, or a fifth of the sample rate when lower) and differentiation.
        `friction` per joint: "coulomb-viscous" (offset + Coulomb sign(v) + viscous v, the
        default), "viscous" or "none" (the offset alone). `method`: "physically-consistent"
        (every body's pseudo-inertia positive semidefinite, a semidefinite program regularized
        toward the model's values; the default) or "least-squares" (`weighted` False: ordinary).
        The last `validation_fraction` of the log (by time) is held out and predicted.
        `payload_frame`: identify only a payload held at that frame (the answer's `payload` is a
        `Payload`). `include_series`: also answer the measured and predicted torques on the
        held-out part.

        Returns an `Identification`: `parameters`, `bodies`, `friction`, `base_parameters`
        (expressions, values, standard deviations), `condition_number`,
        `physically_consistent`, `rmse` (train, validation, validation_before per joint) and
        `robot`/`robot_id` of the stored variant. The fit runs on the server in a worker process
        with a time limit (several seconds for tens of thousands of samples). Raises
        `UnsupportedModelError` for a free-flyer or planar base, `ValidationError` for a log it
        cannot identify from (non-increasing t, too few samples — the detail says how many are
        needed —, a motion that reveals too little), `DimensionMismatchError` for wrong widths.
        `progress`: a callable (done, total) or True for a tqdm bar (the client's by default):
        the server streams the fit's stages as they start, once the log is checked (base
        parameters, regressor, fit, validation: done 1 to 4 of 5; `robodyn.progress`).
        """
        return await self._send(
            calls.identify(
                robot_id,
                t,
                q,
                tau,
                v=v,
                a=a,
                friction=friction,
                method=method,
                weighted=weighted,
                validation_fraction=validation_fraction,
                filter_hz=filter_hz,
                store=store,
                payload_frame=payload_frame,
                include_series=include_series,
            ),
            progress,
        )
