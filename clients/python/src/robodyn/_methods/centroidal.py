"""Client methods of the centroidal momentum and its matrix (`Client` and `AsyncClient` inherit
them). Shapes and units as in `robodyn._methods.equation_of_motion`."""

from __future__ import annotations

from robodyn._calls import centroidal as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.arrays import ArrayLike
from robodyn.payloads import PayloadsLike
from robodyn.results import Centroidal


class CentroidalMethods(SyncSender):
    """The centroidal methods of `Client`."""

    def centroidal(
        self, robot_id: str, q: ArrayLike, v: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> Centroidal:
        """(momentum, momentum_matrix, center_of_mass): the centroidal momentum h = A(q) v, shape
        (6,), linear (kg·m/s) then angular (kg·m²/s) about the centre of mass in world-aligned
        axes; the centroidal momentum matrix A(q), shape (6, nv); the centre of mass, shape (3,),
        m. A leading axis N for a batch. `payloads`: rigid bodies the robot holds (`Payload`s),
        added to its model for this call.
        """
        return self._send(calls.centroidal(robot_id, q, v, payloads=payloads))


class AsyncCentroidalMethods(AsyncSender):
    """The centroidal methods of `AsyncClient`."""

    async def centroidal(
        self, robot_id: str, q: ArrayLike, v: ArrayLike, *, payloads: PayloadsLike | None = None
    ) -> Centroidal:
        """(momentum, momentum_matrix, center_of_mass): the centroidal momentum h = A(q) v, shape
        (6,), linear (kg·m/s) then angular (kg·m²/s) about the centre of mass in world-aligned
        axes; the centroidal momentum matrix A(q), shape (6, nv); the centre of mass, shape (3,),
        m. A leading axis N for a batch. `payloads`: rigid bodies the robot holds (`Payload`s),
        added to its model for this call.
        """
        return await self._send(calls.centroidal(robot_id, q, v, payloads=payloads))
