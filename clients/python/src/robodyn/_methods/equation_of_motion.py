"""Client methods of the equation of motion M(q) a + C(q, v) v + g(q) = τ: its terms, inverse
and forward dynamics (`Client` and `AsyncClient` inherit them).

Shapes: `nq` is the length of q and `nv` that of v, a and τ (see `RobotInfo.joints`). A 1-D
input is one state; 2-D inputs of shape (N, n) are N states and every output gains a leading
axis N. Units: SI — q in rad or m, v in rad/s or m/s, a in rad/s² or m/s², τ in N·m or N.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from robodyn._calls import equation_of_motion as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.arrays import ArrayLike
from robodyn.payloads import PayloadsLike


class EquationOfMotionMethods(SyncSender):
    """The equation-of-motion methods of `Client`."""

    def mass_matrix(
        self, robot_id: str, q: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> np.ndarray:
        """M(q), the joint-space inertia matrix (CRBA): symmetric positive definite, kg·m² (kg on
        prismatic rows), shape (nv, nv), or (N, nv, nv) for q of shape (N, nq). The kinetic energy
        is ½ vᵀ M v. `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for
        this call.
        """
        return self._send(calls.mass_matrix(robot_id, q, payloads=payloads))

    def gravity(
        self, robot_id: str, q: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> np.ndarray:
        """g(q), the generalized gravity torques (the gradient of the potential energy), N·m or N,
        shape (nv,), or (N, nv) for q of shape (N, nq). `payloads`: rigid bodies the robot holds
        (`Payload`s), added to its model for this call.
        """
        return self._send(calls.gravity(robot_id, q, payloads=payloads))

    def coriolis(
        self, robot_id: str, q: ArrayLike, v: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(C, C v): the Coriolis/centrifugal matrix C(q, v) with Ṁ = C + Cᵀ, N·m·s, shape (nv,
        nv), and the forces C(q, v) v, N·m or N, shape (nv,); with a batch axis N for inputs of
        shape (N, nq) and (N, nv). `payloads`: rigid bodies the robot holds (`Payload`s), added to
        its model for this call.
        """
        return self._send(calls.coriolis(robot_id, q, v, payloads=payloads))

    def nonlinear_effects(
        self, robot_id: str, q: ArrayLike, v: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> np.ndarray:
        """h(q, v) = C(q, v) v + g(q) (gravity included, as in Pinocchio), N·m or N, shape (nv,),
        or (N, nv) for a batch. `payloads`: rigid bodies the robot holds (`Payload`s), added to its
        model for this call.
        """
        return self._send(calls.nonlinear_effects(robot_id, q, v, payloads=payloads))

    def inverse_dynamics(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        a: ArrayLike,
        *,
        external_forces: Sequence[Mapping[str, Any]] | None = None,
        payloads: PayloadsLike | None = None,
        friction: bool = False,
    ) -> np.ndarray:
        """τ = M(q) a + C(q, v) v + g(q) (RNEA): the generalized forces, N·m or N, that give the
        accelerations a (rad/s² or m/s²); shape (nv,), or (N, nv) for a batch. `external_forces`:
        wrenches the environment applies, `[{"frame": "tool0", "wrench": [fx, fy, fz, tx, ty, tz],
        "reference_frame": "local_world_aligned"}]` (N, N·m; a wrench may be (N, 6), one per
        state); then τ = M a + C v + g − Σ Jᵀ w. `payloads`: rigid bodies the robot holds
        (`Payload`s), added to its model for this call. `friction`: add the joints' friction
        (offset + Coulomb sign(v) + viscous v) of a robot stored by `identify`.
        """
        return self._send(
            calls.inverse_dynamics(
                robot_id,
                q,
                v,
                a,
                external_forces=external_forces,
                payloads=payloads,
                friction=friction,
            )
        )

    def joint_wrenches(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        a: ArrayLike,
        *,
        external_forces: Sequence[Mapping[str, Any]] | None = None,
        payloads: PayloadsLike | None = None,
        friction: bool = False,
    ) -> tuple[np.ndarray, np.ndarray]:
        """(τ, wrenches): τ = M(q) a + C(q, v) v + g(q) as `inverse_dynamics` gives it, shape
        (nv,), and the wrench each moving joint transmits from its parent body to its child
        body (Pinocchio's RNEA `data.f`), shape (joints, 6); (N, nv) and (N, joints, 6) for a
        batch. One row per joint of the robot's `joints` in order: force f (N) then moment n
        (N·m) about the joint frame's origin, in the joint frame's axes. For a revolute joint
        with unit axis s, τ = s · n and its bearings carry the axial force |s · f| and the
        bending moment ‖n − (s · n) s‖. `external_forces` as for `inverse_dynamics`;
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this
        call; `friction`: add the joints' friction of a robot stored by `identify` (along
        each joint's axis in its wrench).
        """
        return self._send(
            calls.joint_wrenches(
                robot_id,
                q,
                v,
                a,
                external_forces=external_forces,
                payloads=payloads,
                friction=friction,
            )
        )

    def forward_dynamics(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        tau: ArrayLike,
        *,
        external_forces: Sequence[Mapping[str, Any]] | None = None,
        payloads: PayloadsLike | None = None,
    ) -> np.ndarray:
        """a = M(q)⁻¹ (τ − C(q, v) v − g(q)) (ABA): the accelerations, rad/s² or m/s², that the
        generalized forces τ (N·m or N) produce; shape (nv,), or (N, nv) for a batch.
        `external_forces` as for `inverse_dynamics`: then a = M⁻¹ (τ − C v − g + Σ Jᵀ w).
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return self._send(
            calls.forward_dynamics(
                robot_id, q, v, tau, external_forces=external_forces, payloads=payloads
            )
        )


class AsyncEquationOfMotionMethods(AsyncSender):
    """The equation-of-motion methods of `AsyncClient`."""

    async def mass_matrix(
        self, robot_id: str, q: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> np.ndarray:
        """M(q), the joint-space inertia matrix (CRBA): symmetric positive definite, kg·m² (kg on
        prismatic rows), shape (nv, nv), or (N, nv, nv) for q of shape (N, nq). The kinetic energy
        is ½ vᵀ M v. `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for
        this call.
        """
        return await self._send(calls.mass_matrix(robot_id, q, payloads=payloads))

    async def gravity(
        self, robot_id: str, q: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> np.ndarray:
        """g(q), the generalized gravity torques (the gradient of the potential energy), N·m or N,
        shape (nv,), or (N, nv) for q of shape (N, nq). `payloads`: rigid bodies the robot holds
        (`Payload`s), added to its model for this call.
        """
        return await self._send(calls.gravity(robot_id, q, payloads=payloads))

    async def coriolis(
        self, robot_id: str, q: ArrayLike, v: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(C, C v): the Coriolis/centrifugal matrix C(q, v) with Ṁ = C + Cᵀ, N·m·s, shape (nv,
        nv), and the forces C(q, v) v, N·m or N, shape (nv,); with a batch axis N for inputs of
        shape (N, nq) and (N, nv). `payloads`: rigid bodies the robot holds (`Payload`s), added to
        its model for this call.
        """
        return await self._send(calls.coriolis(robot_id, q, v, payloads=payloads))

    async def nonlinear_effects(
        self, robot_id: str, q: ArrayLike, v: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> np.ndarray:
        """h(q, v) = C(q, v) v + g(q) (gravity included, as in Pinocchio), N·m or N, shape (nv,),
        or (N, nv) for a batch. `payloads`: rigid bodies the robot holds (`Payload`s), added to its
        model for this call.
        """
        return await self._send(calls.nonlinear_effects(robot_id, q, v, payloads=payloads))

    async def inverse_dynamics(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        a: ArrayLike,
        *,
        external_forces: Sequence[Mapping[str, Any]] | None = None,
        payloads: PayloadsLike | None = None,
        friction: bool = False,
    ) -> np.ndarray:
        """τ = M(q) a + C(q, v) v + g(q) (RNEA): the generalized forces, N·m or N, that give the
        accelerations a (rad/s² or m/s²); shape (nv,), or (N, nv) for a batch. `external_forces`:
        wrenches the environment applies, `[{"frame": "tool0", "wrench": [fx, fy, fz, tx, ty, tz],
        "reference_frame": "local_world_aligned"}]` (N, N·m; a wrench may be (N, 6), one per
        state); then τ = M a + C v + g − Σ Jᵀ w. `payloads`: rigid bodies the robot holds
        (`Payload`s), added to its model for this call. `friction`: add the joints' friction
        (offset + Coulomb sign(v) + viscous v) of a robot stored by `identify`.
        """
        return await self._send(
            calls.inverse_dynamics(
                robot_id,
                q,
                v,
                a,
                external_forces=external_forces,
                payloads=payloads,
                friction=friction,
            )
        )

    async def joint_wrenches(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        a: ArrayLike,
        *,
        external_forces: Sequence[Mapping[str, Any]] | None = None,
        payloads: PayloadsLike | None = None,
        friction: bool = False,
    ) -> tuple[np.ndarray, np.ndarray]:
        """(τ, wrenches): τ = M(q) a + C(q, v) v + g(q) as `inverse_dynamics` gives it, shape
        (nv,), and the wrench each moving joint transmits from its parent body to its child
        body (Pinocchio's RNEA `data.f`), shape (joints, 6); (N, nv) and (N, joints, 6) for a
        batch. One row per joint of the robot's `joints` in order: force f (N) then moment n
        (N·m) about the joint frame's origin, in the joint frame's axes. For a revolute joint
        with unit axis s, τ = s · n and its bearings carry the axial force |s · f| and the
        bending moment ‖n − (s · n) s‖. `external_forces` as for `inverse_dynamics`;
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this
        call; `friction`: add the joints' friction of a robot stored by `identify` (along
        each joint's axis in its wrench).
        """
        return await self._send(
            calls.joint_wrenches(
                robot_id,
                q,
                v,
                a,
                external_forces=external_forces,
                payloads=payloads,
                friction=friction,
            )
        )

    async def forward_dynamics(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        tau: ArrayLike,
        *,
        external_forces: Sequence[Mapping[str, Any]] | None = None,
        payloads: PayloadsLike | None = None,
    ) -> np.ndarray:
        """a = M(q)⁻¹ (τ − C(q, v) v − g(q)) (ABA): the accelerations, rad/s² or m/s², that the
        generalized forces τ (N·m or N) produce; shape (nv,), or (N, nv) for a batch.
        `external_forces` as for `inverse_dynamics`: then a = M⁻¹ (τ − C v − g + Σ Jᵀ w).
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return await self._send(
            calls.forward_dynamics(
                robot_id, q, v, tau, external_forces=external_forces, payloads=payloads
            )
        )
