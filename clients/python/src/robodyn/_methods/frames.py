"""Client methods of a frame's Jacobian J(q) and its time variation J̇(q, v) (`Client` and
`AsyncClient` inherit them). Shapes and units as in `robodyn._methods.equation_of_motion`."""

from __future__ import annotations

from robodyn._calls import frames as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.arrays import ArrayLike
from robodyn.payloads import PayloadsLike
from robodyn.request_options import ReferenceFrame
from robodyn.results import FrameJacobian


class FrameMethods(SyncSender):
    """The frame Jacobian methods of `Client`."""

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


class AsyncFrameMethods(AsyncSender):
    """The frame Jacobian methods of `AsyncClient`."""

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
