"""Client methods of the quantities beyond the equation of motion: M⁻¹, energy, centre of
mass, frame Jacobians, operational-space dynamics and the payload capacity (`Client` and
`AsyncClient` inherit them). Shapes and units as in `robodyn._methods.dynamics`."""

from __future__ import annotations

from typing import Any

import numpy as np

from robodyn._calls import beyond as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.arrays import ArrayLike
from robodyn.payloads import PayloadCapacity, PayloadsLike
from robodyn.request_options import ReferenceFrame, Task
from robodyn.results import CenterOfMass, Energy, FrameJacobian, OperationalSpace


class BeyondMethods(SyncSender):
    """The methods beyond the equation of motion of `Client`."""

    def mass_matrix_inverse(
        self, robot_id: str, q: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> np.ndarray:
        """M(q)⁻¹, the inverse joint-space inertia matrix (Pinocchio's computeMinverse, no
        numerical inversion): symmetric positive definite, 1/(kg·m²) (1/kg on prismatic rows),
        shape (nv, nv), or (N, nv, nv) for q of shape (N, nq). `payloads`: rigid bodies the robot
        holds (`Payload`s), added to its model for this call.
        """
        return self._send(calls.mass_matrix_inverse(robot_id, q, payloads=payloads))

    def energy(
        self, robot_id: str, q: ArrayLike, v: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> Energy:
        """`Energy` with `kinetic_energy` T = ½ vᵀ M v, `potential_energy` U (zero at the world
        origin, g(q) = ∂U/∂q) and `mechanical_energy` T + U, in J: floats for one state, arrays of
        shape (N,) for a batch. Along any motion d(T + U)/dt = vᵀ τ (τ the applied torques).
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return self._send(calls.energy(robot_id, q, v, payloads=payloads))

    def center_of_mass(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike | None = None,
        *,
        payloads: PayloadsLike | None = None,
    ) -> CenterOfMass:
        """`CenterOfMass` of the whole robot in the world frame: `position` shape (3,) in m,
        `jacobian` ∂c/∂q shape (3, nv), and with v `velocity` shape (3,) in m/s (else None); a
        leading axis N for a batch. `payloads`: rigid bodies the robot holds (`Payload`s), added to
        its model for this call.
        """
        return self._send(calls.center_of_mass(robot_id, q, v, payloads=payloads))

    def jacobian(
        self,
        robot_id: str,
        q: ArrayLike,
        frame: str,
        *,
        reference_frame: ReferenceFrame = "local_world_aligned",
        v: ArrayLike | None = None,
        payloads: PayloadsLike | None = None,
    ) -> FrameJacobian:
        """`FrameJacobian` of the frame named `frame` (a link, joint or fixed frame:
        `robot(id).frame_names`): `jacobian` J, shape (6, nv), rows [vx, vy, vz, ωx, ωy, ωz] in
        `reference_frame` ("local_world_aligned", "local" or "world"), so the frame's velocity is J
        v; with v also `jacobian_time_variation` J̇, shape (6, nv) (acceleration J a + J̇ v). A
        leading axis N for a batch. Raises `UnknownFrameError` for a name the robot lacks.
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return self._send(
            calls.jacobian(
                robot_id, q, frame, reference_frame=reference_frame, v=v, payloads=payloads
            )
        )

    def operational_space(
        self,
        robot_id: str,
        q: ArrayLike,
        frame: str,
        *,
        v: ArrayLike | None = None,
        reference_frame: ReferenceFrame = "local_world_aligned",
        task: Task = "full",
        damping: float = 0.0,
        payloads: PayloadsLike | None = None,
    ) -> OperationalSpace:
        """`OperationalSpace` of `frame` (Khatib): `inertia` Λ = (J M⁻¹ Jᵀ)⁻¹ shape (k, k),
        `jacobian` J shape (k, nv), `dynamically_consistent_inverse` J̄ = M⁻¹ Jᵀ Λ shape (nv, k),
        `gravity` p = J̄ᵀ g shape (k,) and with v `coriolis` μ = J̄ᵀ C v − Λ J̇ v shape (k,); k = 6
        for `task` "full" ([linear; angular]), 3 for "linear" or "angular". SI units: kg and kg·m²,
        N and N·m. A leading axis N for a batch. At a singular configuration (smallest singular
        value of J M⁻¹ Jᵀ at most 1e-8 times its largest) raises `SingularConfigurationError`
        unless `damping` λ > 0, which uses (J M⁻¹ Jᵀ + λ² I)⁻¹. `payloads`: rigid bodies the robot
        holds (`Payload`s), added to its model for this call.
        """
        return self._send(
            calls.operational_space(
                robot_id,
                q,
                frame,
                v=v,
                reference_frame=reference_frame,
                task=task,
                damping=damping,
                payloads=payloads,
            )
        )

    def payload_capacity(
        self,
        robot_id: str,
        q: ArrayLike,
        frame: str,
        *,
        center_of_mass: ArrayLike | None = None,
        v: ArrayLike | None = None,
        a: ArrayLike | None = None,
        effort_limits: Any = None,
        payloads: PayloadsLike | None = None,
    ) -> PayloadCapacity:
        """`PayloadCapacity`: the heaviest point mass (kg) the robot can hold at `center_of_mass`
        (shape (3,), m, in the axes of `frame` from its origin; default the origin) with no joint
        torque over its effort limit, exact: τ(m) = τ₀ + m τ₁ is affine in the mass. `q` one
        state (nq,) or a batch (N, nq) (e.g. a trajectory); `v`, `a` (default zero: holding
        still) add the motion's share. Its `mass` (inf where no joint limits it, 0 where a joint
        is over its limit with no payload), `limiting_joint`, `mass_per_joint` (nv,) and `tau`
        at that mass (nv,); a batch adds a leading axis N and `minimum` (the smallest capacity
        and its state). `effort_limits` (nv values ≥ 0, N·m or N, 0 = no limit; an array or a
        mapping by joint name) replaces the model's; a floating root's rows never limit.
        `payloads`: rigid bodies the robot already holds (`Payload`s), counted in τ₀. Raises
        `UnknownFrameError` for a name the robot lacks.
        """
        return self._send(
            calls.payload_capacity(
                robot_id,
                q,
                frame,
                center_of_mass=center_of_mass,
                v=v,
                a=a,
                effort_limits=effort_limits,
                payloads=payloads,
            )
        )


class AsyncBeyondMethods(AsyncSender):
    """The methods beyond the equation of motion of `AsyncClient`."""

    async def mass_matrix_inverse(
        self, robot_id: str, q: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> np.ndarray:
        """M(q)⁻¹, the inverse joint-space inertia matrix (Pinocchio's computeMinverse, no
        numerical inversion): symmetric positive definite, 1/(kg·m²) (1/kg on prismatic rows),
        shape (nv, nv), or (N, nv, nv) for q of shape (N, nq). `payloads`: rigid bodies the robot
        holds (`Payload`s), added to its model for this call.
        """
        return await self._send(calls.mass_matrix_inverse(robot_id, q, payloads=payloads))

    async def energy(
        self, robot_id: str, q: ArrayLike, v: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> Energy:
        """`Energy` with `kinetic_energy` T = ½ vᵀ M v, `potential_energy` U (zero at the world
        origin, g(q) = ∂U/∂q) and `mechanical_energy` T + U, in J: floats for one state, arrays of
        shape (N,) for a batch. Along any motion d(T + U)/dt = vᵀ τ (τ the applied torques).
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return await self._send(calls.energy(robot_id, q, v, payloads=payloads))

    async def center_of_mass(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike | None = None,
        *,
        payloads: PayloadsLike | None = None,
    ) -> CenterOfMass:
        """`CenterOfMass` of the whole robot in the world frame: `position` shape (3,) in m,
        `jacobian` ∂c/∂q shape (3, nv), and with v `velocity` shape (3,) in m/s (else None); a
        leading axis N for a batch. `payloads`: rigid bodies the robot holds (`Payload`s), added to
        its model for this call.
        """
        return await self._send(calls.center_of_mass(robot_id, q, v, payloads=payloads))

    async def jacobian(
        self,
        robot_id: str,
        q: ArrayLike,
        frame: str,
        *,
        reference_frame: ReferenceFrame = "local_world_aligned",
        v: ArrayLike | None = None,
        payloads: PayloadsLike | None = None,
    ) -> FrameJacobian:
        """`FrameJacobian` of the frame named `frame` (a link, joint or fixed frame:
        `robot(id).frame_names`): `jacobian` J, shape (6, nv), rows [vx, vy, vz, ωx, ωy, ωz] in
        `reference_frame` ("local_world_aligned", "local" or "world"), so the frame's velocity is J
        v; with v also `jacobian_time_variation` J̇, shape (6, nv) (acceleration J a + J̇ v). A
        leading axis N for a batch. Raises `UnknownFrameError` for a name the robot lacks.
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return await self._send(
            calls.jacobian(
                robot_id, q, frame, reference_frame=reference_frame, v=v, payloads=payloads
            )
        )

    async def operational_space(
        self,
        robot_id: str,
        q: ArrayLike,
        frame: str,
        *,
        v: ArrayLike | None = None,
        reference_frame: ReferenceFrame = "local_world_aligned",
        task: Task = "full",
        damping: float = 0.0,
        payloads: PayloadsLike | None = None,
    ) -> OperationalSpace:
        """`OperationalSpace` of `frame` (Khatib): `inertia` Λ = (J M⁻¹ Jᵀ)⁻¹ shape (k, k),
        `jacobian` J shape (k, nv), `dynamically_consistent_inverse` J̄ = M⁻¹ Jᵀ Λ shape (nv, k),
        `gravity` p = J̄ᵀ g shape (k,) and with v `coriolis` μ = J̄ᵀ C v − Λ J̇ v shape (k,); k = 6
        for `task` "full" ([linear; angular]), 3 for "linear" or "angular". SI units: kg and kg·m²,
        N and N·m. A leading axis N for a batch. At a singular configuration (smallest singular
        value of J M⁻¹ Jᵀ at most 1e-8 times its largest) raises `SingularConfigurationError`
        unless `damping` λ > 0, which uses (J M⁻¹ Jᵀ + λ² I)⁻¹. `payloads`: rigid bodies the robot
        holds (`Payload`s), added to its model for this call.
        """
        return await self._send(
            calls.operational_space(
                robot_id,
                q,
                frame,
                v=v,
                reference_frame=reference_frame,
                task=task,
                damping=damping,
                payloads=payloads,
            )
        )

    async def payload_capacity(
        self,
        robot_id: str,
        q: ArrayLike,
        frame: str,
        *,
        center_of_mass: ArrayLike | None = None,
        v: ArrayLike | None = None,
        a: ArrayLike | None = None,
        effort_limits: Any = None,
        payloads: PayloadsLike | None = None,
    ) -> PayloadCapacity:
        """`PayloadCapacity`: the heaviest point mass (kg) the robot can hold at `center_of_mass`
        (shape (3,), m, in the axes of `frame` from its origin; default the origin) with no joint
        torque over its effort limit, exact: τ(m) = τ₀ + m τ₁ is affine in the mass. `q` one
        state (nq,) or a batch (N, nq) (e.g. a trajectory); `v`, `a` (default zero: holding
        still) add the motion's share. Its `mass` (inf where no joint limits it, 0 where a joint
        is over its limit with no payload), `limiting_joint`, `mass_per_joint` (nv,) and `tau`
        at that mass (nv,); a batch adds a leading axis N and `minimum` (the smallest capacity
        and its state). `effort_limits` (nv values ≥ 0, N·m or N, 0 = no limit; an array or a
        mapping by joint name) replaces the model's; a floating root's rows never limit.
        `payloads`: rigid bodies the robot already holds (`Payload`s), counted in τ₀. Raises
        `UnknownFrameError` for a name the robot lacks.
        """
        return await self._send(
            calls.payload_capacity(
                robot_id,
                q,
                frame,
                center_of_mass=center_of_mass,
                v=v,
                a=a,
                effort_limits=effort_limits,
                payloads=payloads,
            )
        )
