"""Client methods of rigid contacts: constrained forward dynamics, contact-consistent inverse
dynamics and impacts (`Client` and `AsyncClient` inherit them; simulation with contacts is
`simulate(..., contacts=...)`). Contact forces are at each frame's origin with the world's
axes, 3 numbers per "point" contact (N) and 6 per "6d" contact (N, then N·m), m in all."""

from __future__ import annotations

from robodyn._calls import contacts as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.arrays import ArrayLike
from robodyn.contacts import (
    ContactDynamics,
    ContactInverseDynamics,
    ContactsLike,
    ImpulseDynamics,
)
from robodyn.payloads import PayloadsLike


class ContactMethods(SyncSender):
    """The contact methods of `Client`."""

    def contact_dynamics(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        tau: ArrayLike,
        contacts: ContactsLike,
        *,
        damping: float = 0.0,
        payloads: PayloadsLike | None = None,
    ) -> ContactDynamics:
        """`ContactDynamics` (a, contact_forces): constrained forward dynamics with rigid contacts,
        M a + h = τ + Jcᵀ λ with Jc a + γ = 0. `contacts`: a list of `{"frame": name, "type":
        "point" | "6d"}` (a robot's feet: `RobotInfo.contact_frames`). `a` has shape (nv,) and
        `contact_forces` (m,) — N (and N·m for 6d contacts), at each frame's origin with the
        world's axes, in the order of `contacts`; a leading axis N for a batch. Raises
        `UnknownFrameError` for an unknown frame and `SingularConfigurationError` for a
        rank-deficient contact set unless `damping` μ > 0 (the regularized solution). `payloads`:
        rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return self._send(
            calls.contact_dynamics(
                robot_id, q, v, tau, contacts, damping=damping, payloads=payloads
            )
        )

    def contact_inverse_dynamics(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        a: ArrayLike,
        contacts: ContactsLike,
        *,
        damping: float = 0.0,
        payloads: PayloadsLike | None = None,
    ) -> ContactInverseDynamics:
        """`ContactInverseDynamics` (tau, contact_forces, residual): the joint torques τ (zero on a
        floating base's root rows) and the minimum-norm contact forces λ with M a + h = τ + Jcᵀ λ;
        `residual` is the 2-norm of the root wrench no contact force can produce (0 when the
        contacts can hold the motion). The shapes: τ (nv,), λ (m,), laid out as in
        `contact_dynamics`, residual a float; a leading axis N for a batch. No friction cone: λ may
        pull. For a fixed-base robot λ = 0 and τ = M a + h. Errors as `contact_dynamics`.
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return self._send(
            calls.contact_inverse_dynamics(
                robot_id, q, v, a, contacts, damping=damping, payloads=payloads
            )
        )

    def impulse_dynamics(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        contacts: ContactsLike,
        *,
        restitution: float = 0.0,
        damping: float = 0.0,
        payloads: PayloadsLike | None = None,
    ) -> ImpulseDynamics:
        """`ImpulseDynamics` (v, contact_impulses): the velocity just after a rigid impact at
        `contacts`, M (v⁺ − v⁻) = Jcᵀ Λ with Jc v⁺ = −e Jc v⁻ (`restitution` e in [0, 1]), and the
        impulses Λ in N·s (N·m·s), laid out like contact forces. The shapes: v (nv,), Λ (m,); a
        leading axis N for a batch. Errors as `contact_dynamics`. `payloads`: rigid bodies the
        robot holds (`Payload`s), added to its model for this call.
        """
        return self._send(
            calls.impulse_dynamics(
                robot_id,
                q,
                v,
                contacts,
                restitution=restitution,
                damping=damping,
                payloads=payloads,
            )
        )


class AsyncContactMethods(AsyncSender):
    """The contact methods of `AsyncClient`."""

    async def contact_dynamics(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        tau: ArrayLike,
        contacts: ContactsLike,
        *,
        damping: float = 0.0,
        payloads: PayloadsLike | None = None,
    ) -> ContactDynamics:
        """`ContactDynamics` (a, contact_forces): constrained forward dynamics with rigid contacts,
        M a + h = τ + Jcᵀ λ with Jc a + γ = 0. `contacts`: a list of `{"frame": name, "type":
        "point" | "6d"}` (a robot's feet: `RobotInfo.contact_frames`). `a` has shape (nv,) and
        `contact_forces` (m,) — N (and N·m for 6d contacts), at each frame's origin with the
        world's axes, in the order of `contacts`; a leading axis N for a batch. Raises
        `UnknownFrameError` for an unknown frame and `SingularConfigurationError` for a
        rank-deficient contact set unless `damping` μ > 0 (the regularized solution). `payloads`:
        rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return await self._send(
            calls.contact_dynamics(
                robot_id, q, v, tau, contacts, damping=damping, payloads=payloads
            )
        )

    async def contact_inverse_dynamics(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        a: ArrayLike,
        contacts: ContactsLike,
        *,
        damping: float = 0.0,
        payloads: PayloadsLike | None = None,
    ) -> ContactInverseDynamics:
        """`ContactInverseDynamics` (tau, contact_forces, residual): the joint torques τ (zero on a
        floating base's root rows) and the minimum-norm contact forces λ with M a + h = τ + Jcᵀ λ;
        `residual` is the 2-norm of the root wrench no contact force can produce (0 when the
        contacts can hold the motion). The shapes: τ (nv,), λ (m,), laid out as in
        `contact_dynamics`, residual a float; a leading axis N for a batch. No friction cone: λ may
        pull. For a fixed-base robot λ = 0 and τ = M a + h. Errors as `contact_dynamics`.
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return await self._send(
            calls.contact_inverse_dynamics(
                robot_id, q, v, a, contacts, damping=damping, payloads=payloads
            )
        )

    async def impulse_dynamics(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        contacts: ContactsLike,
        *,
        restitution: float = 0.0,
        damping: float = 0.0,
        payloads: PayloadsLike | None = None,
    ) -> ImpulseDynamics:
        """`ImpulseDynamics` (v, contact_impulses): the velocity just after a rigid impact at
        `contacts`, M (v⁺ − v⁻) = Jcᵀ Λ with Jc v⁺ = −e Jc v⁻ (`restitution` e in [0, 1]), and the
        impulses Λ in N·s (N·m·s), laid out like contact forces. The shapes: v (nv,), Λ (m,); a
        leading axis N for a batch. Errors as `contact_dynamics`. `payloads`: rigid bodies the
        robot holds (`Payload`s), added to its model for this call.
        """
        return await self._send(
            calls.impulse_dynamics(
                robot_id,
                q,
                v,
                contacts,
                restitution=restitution,
                damping=damping,
                payloads=payloads,
            )
        )
