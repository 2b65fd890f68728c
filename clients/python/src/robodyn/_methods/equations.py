"""Client methods of the equations of motion in explicit form (`Client` and `AsyncClient`
inherit them)."""

from __future__ import annotations

from robodyn._calls import equations as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.equations import Equations


class EquationsMethods(SyncSender):
    """The explicit-equations methods of `Client`."""

    def equations(self, robot_id: str) -> Equations:
        """The equations of motion in explicit form, M(q) q̈ + C(q, q̇) q̇ + g(q) = τ, derived
        symbolically by the server from the model's own numbers, for a fixed-base robot with at
        most 6 moving joints, each revolute or prismatic: `Equations` with M(q), g(q), C(q, q̇),
        the Christoffel symbols c_ijk and the energies T and U, each as text SymPy parses
        (`.expressions`), LaTeX (`.latex`) and, with SymPy installed (the `sympy` extra),
        SymPy objects (`.sympy()`); and the structure of M and g (per entry: the coordinates
        it depends on, constant, zero). Coordinates q1 … qn follow `joints` (rad or m).

        The server derives a robot's equations on its first request (a UR5: about 0.3 s; at
        most its ROBODYN_EQUATIONS_TIMEOUT_S, 60 s by default) and keeps them. Raises
        `RobotNotFoundError` for an unknown id, `UnsupportedModelError` for a model out of scope
        (a floating base, a continuous or multi-DoF joint, more than 6 moving joints, or a
        derivation past the server's time limit), the detail saying which.
        """
        return self._send(calls.equations(robot_id))


class AsyncEquationsMethods(AsyncSender):
    """The explicit-equations methods of `AsyncClient`."""

    async def equations(self, robot_id: str) -> Equations:
        """The equations of motion in explicit form, M(q) q̈ + C(q, q̇) q̇ + g(q) = τ, derived
        symbolically by the server from the model's own numbers, for a fixed-base robot with at
        most 6 moving joints, each revolute or prismatic: `Equations` with M(q), g(q), C(q, q̇),
        the Christoffel symbols c_ijk and the energies T and U, each as text SymPy parses
        (`.expressions`), LaTeX (`.latex`) and, with SymPy installed (the `sympy` extra),
        SymPy objects (`.sympy()`); and the structure of M and g (per entry: the coordinates
        it depends on, constant, zero). Coordinates q1 … qn follow `joints` (rad or m).

        The server derives a robot's equations on its first request (a UR5: about 0.3 s; at
        most its ROBODYN_EQUATIONS_TIMEOUT_S, 60 s by default) and keeps them. Raises
        `RobotNotFoundError` for an unknown id, `UnsupportedModelError` for a model out of scope
        (a floating base, a continuous or multi-DoF joint, more than 6 moving joints, or a
        derivation past the server's time limit), the detail saying which.
        """
        return await self._send(calls.equations(robot_id))
