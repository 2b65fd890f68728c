"""Client methods of the model check (`Client` and `AsyncClient` inherit them)."""

from __future__ import annotations

from robodyn._calls import model_check as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.model_check import ModelCheck


class ModelCheckMethods(SyncSender):
    """The model check methods of `Client`."""

    def model_check(self, robot_id: str) -> ModelCheck:
        """The inertias robot `robot_id`'s description claims, against physics and each link's
        geometry: a `ModelCheck` of `findings` (errors no rigid body has, with a power-of-ten
        `suggestion` where one attribute explains it; warnings for what is rarely meant) and
        `links` (declared mass properties beside the geometry's). Repair with
        `variant(robot_id, inertias={"links": "errors", "from": "geometry"})`. Raises
        `RobotNotFoundError` for an unknown id.
        """
        return self._send(calls.model_check(robot_id))


class AsyncModelCheckMethods(AsyncSender):
    """The model check methods of `AsyncClient`."""

    async def model_check(self, robot_id: str) -> ModelCheck:
        """The inertias robot `robot_id`'s description claims, against physics and each link's
        geometry: a `ModelCheck` of `findings` (errors no rigid body has, with a power-of-ten
        `suggestion` where one attribute explains it; warnings for what is rarely meant) and
        `links` (declared mass properties beside the geometry's). Repair with
        `variant(robot_id, inertias={"links": "errors", "from": "geometry"})`. Raises
        `RobotNotFoundError` for an unknown id.
        """
        return await self._send(calls.model_check(robot_id))
