"""Client methods of the payload capacity: the heaviest point mass a frame can hold within the
effort limits (`Client` and `AsyncClient` inherit them). Shapes and units as in
`robodyn._methods.equation_of_motion`."""

from __future__ import annotations

from typing import Any

from robodyn._calls import payload_capacity as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.arrays import ArrayLike
from robodyn.payloads import PayloadCapacity, PayloadsLike


class PayloadCapacityMethods(SyncSender):
    """The payload-capacity methods of `Client`."""

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


class AsyncPayloadCapacityMethods(AsyncSender):
    """The payload-capacity methods of `AsyncClient`."""

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
