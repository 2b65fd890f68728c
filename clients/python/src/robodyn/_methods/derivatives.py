"""Client methods of the derivatives of inverse and forward dynamics (`Client` and `AsyncClient`
inherit them). Shapes and units as in `robodyn._methods.equation_of_motion`."""

from __future__ import annotations

from robodyn._calls import derivatives as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.arrays import ArrayLike
from robodyn.payloads import PayloadsLike
from robodyn.results import ForwardDynamicsDerivatives, InverseDynamicsDerivatives


class DerivativeMethods(SyncSender):
    """The derivative methods of `Client`."""

    def inverse_dynamics_derivatives(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        a: ArrayLike,
        *,
        payloads: PayloadsLike | None = None,
    ) -> InverseDynamicsDerivatives:
        """(∂τ/∂q, ∂τ/∂v, ∂τ/∂a = M(q)) of inverse dynamics (analytical RNEA derivatives), each of
        shape (nv, nv), or (N, nv, nv) for a batch. ∂/∂q is on the tangent space: nv columns, along
        q ⊕ δq (for a free-flyer, δq's first 6 entries are a displacement in the base frame).
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return self._send(calls.inverse_dynamics_derivatives(robot_id, q, v, a, payloads=payloads))

    def forward_dynamics_derivatives(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        tau: ArrayLike,
        *,
        payloads: PayloadsLike | None = None,
    ) -> ForwardDynamicsDerivatives:
        """(∂a/∂q, ∂a/∂v, ∂a/∂τ = M(q)⁻¹) of forward dynamics (analytical ABA derivatives), each of
        shape (nv, nv), or (N, nv, nv) for a batch; ∂/∂q on the tangent space (nv columns).
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return self._send(
            calls.forward_dynamics_derivatives(robot_id, q, v, tau, payloads=payloads)
        )


class AsyncDerivativeMethods(AsyncSender):
    """The derivative methods of `AsyncClient`."""

    async def inverse_dynamics_derivatives(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        a: ArrayLike,
        *,
        payloads: PayloadsLike | None = None,
    ) -> InverseDynamicsDerivatives:
        """(∂τ/∂q, ∂τ/∂v, ∂τ/∂a = M(q)) of inverse dynamics (analytical RNEA derivatives), each of
        shape (nv, nv), or (N, nv, nv) for a batch. ∂/∂q is on the tangent space: nv columns, along
        q ⊕ δq (for a free-flyer, δq's first 6 entries are a displacement in the base frame).
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return await self._send(
            calls.inverse_dynamics_derivatives(robot_id, q, v, a, payloads=payloads)
        )

    async def forward_dynamics_derivatives(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        tau: ArrayLike,
        *,
        payloads: PayloadsLike | None = None,
    ) -> ForwardDynamicsDerivatives:
        """(∂a/∂q, ∂a/∂v, ∂a/∂τ = M(q)⁻¹) of forward dynamics (analytical ABA derivatives), each of
        shape (nv, nv), or (N, nv, nv) for a batch; ∂/∂q on the tangent space (nv columns).
        `payloads`: rigid bodies the robot holds (`Payload`s), added to its model for this call.
        """
        return await self._send(
            calls.forward_dynamics_derivatives(robot_id, q, v, tau, payloads=payloads)
        )
