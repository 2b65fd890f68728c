"""Client methods of the Lagrangian quantities: M(q)⁻¹, the energies and the centre of mass
(`Client` and `AsyncClient` inherit them). Shapes and units as in
`robodyn._methods.equation_of_motion`."""

from __future__ import annotations

import numpy as np

from robodyn._calls import lagrangian as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.arrays import ArrayLike
from robodyn.payloads import PayloadsLike
from robodyn.results import CenterOfMass, Energy


class LagrangianMethods(SyncSender):
    """The Lagrangian methods of `Client`."""

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


class AsyncLagrangianMethods(AsyncSender):
    """The Lagrangian methods of `AsyncClient`."""

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
