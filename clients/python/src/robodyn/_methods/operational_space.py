"""Client methods of operational-space dynamics: Khatib's Λ, J̄, μ and p of a frame's task
(`Client` and `AsyncClient` inherit them). Shapes and units as in
`robodyn._methods.equation_of_motion`."""

from __future__ import annotations

from robodyn._calls import operational_space as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.arrays import ArrayLike
from robodyn.payloads import PayloadsLike
from robodyn.request_options import ReferenceFrame, Task
from robodyn.results import OperationalSpace


class OperationalSpaceMethods(SyncSender):
    """The operational-space methods of `Client`."""

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


class AsyncOperationalSpaceMethods(AsyncSender):
    """The operational-space methods of `AsyncClient`."""

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
