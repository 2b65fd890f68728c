"""Client methods of `simulate`, a rollout of forward dynamics (`Client` and `AsyncClient`
inherit them). Shapes and units as in `robodyn._methods.equation_of_motion`."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from robodyn import progress as _progress
from robodyn._calls import simulation as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.arrays import ArrayLike
from robodyn.contacts import ContactsLike, ContactTrajectory
from robodyn.payloads import PayloadsLike
from robodyn.request_options import Integrator
from robodyn.results import Trajectory


class SimulationMethods(SyncSender):
    """The simulation methods of `Client`."""

    def simulate(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        *,
        dt: float,
        steps: int,
        tau: ArrayLike | Mapping[str, Any] | None = None,
        controller: Mapping[str, Any] | None = None,
        integrator: Integrator | None = None,
        contacts: ContactsLike | None = None,
        damping: float = 0.0,
        progress: _progress.Progress = None,
        payloads: PayloadsLike | None = None,
    ) -> Trajectory | ContactTrajectory:
        """Integrate forward dynamics from (q, v) for `steps` steps of `dt` seconds: a `Trajectory`
        (t, q, v, mechanical_energy) of steps + 1 samples, q of shape (steps + 1, nq), v (steps +
        1, nv); with a leading axis N for initial states of shape (N, nq), (N, nv). `tau`: nv
        numbers (constant) or (steps, nv) (τ_k during step k); or `controller`: `{"type": "pd",
        "kp": ..., "kd": ..., "q_target": ..., "gravity_compensation": False}` (gains: a number or
        nv numbers); neither means τ = 0. `integrator`: "semi-implicit-euler" (default) or "rk4".
        `contacts` (a fixed contact set, e.g. `RobotInfo.contact_frames`) gives a
        `ContactTrajectory` (with `constraint_drift`, m): the contacts hold their frames where they
        start, and a PD controller acts on the actuated joints only. `progress` (the client's by
        default): a callable `(done, total)` or True (a tqdm bar) runs more than
        `progress.CHUNK_STEPS` steps in chunks, each from the last state of the one before,
        reporting the steps done after each; the trajectory is bit for bit that of one request. A
        rollout with `contacts` is never chunked by steps. `payloads`: rigid bodies the robot holds
        (`Payload`s), added to its model for this call.
        """
        return self._send(
            calls.simulate(
                robot_id,
                q,
                v,
                dt=dt,
                steps=steps,
                tau=tau,
                controller=controller,
                integrator=integrator,
                contacts=contacts,
                damping=damping,
                payloads=payloads,
            ),
            progress,
        )


class AsyncSimulationMethods(AsyncSender):
    """The simulation methods of `AsyncClient`."""

    async def simulate(
        self,
        robot_id: str,
        q: ArrayLike,
        v: ArrayLike,
        *,
        dt: float,
        steps: int,
        tau: ArrayLike | Mapping[str, Any] | None = None,
        controller: Mapping[str, Any] | None = None,
        integrator: Integrator | None = None,
        contacts: ContactsLike | None = None,
        damping: float = 0.0,
        progress: _progress.Progress = None,
        payloads: PayloadsLike | None = None,
    ) -> Trajectory | ContactTrajectory:
        """Integrate forward dynamics from (q, v) for `steps` steps of `dt` seconds: a `Trajectory`
        (t, q, v, mechanical_energy) of steps + 1 samples, q of shape (steps + 1, nq), v (steps +
        1, nv); with a leading axis N for initial states of shape (N, nq), (N, nv). `tau`: nv
        numbers (constant) or (steps, nv) (τ_k during step k); or `controller`: `{"type": "pd",
        "kp": ..., "kd": ..., "q_target": ..., "gravity_compensation": False}` (gains: a number or
        nv numbers); neither means τ = 0. `integrator`: "semi-implicit-euler" (default) or "rk4".
        `contacts` (a fixed contact set, e.g. `RobotInfo.contact_frames`) gives a
        `ContactTrajectory` (with `constraint_drift`, m): the contacts hold their frames where they
        start, and a PD controller acts on the actuated joints only. `progress` (the client's by
        default): a callable `(done, total)` or True (a tqdm bar) runs more than
        `progress.CHUNK_STEPS` steps in chunks, each from the last state of the one before,
        reporting the steps done after each; the trajectory is bit for bit that of one request. A
        rollout with `contacts` is never chunked by steps. `payloads`: rigid bodies the robot holds
        (`Payload`s), added to its model for this call.
        """
        return await self._send(
            calls.simulate(
                robot_id,
                q,
                v,
                dt=dt,
                steps=steps,
                tau=tau,
                controller=controller,
                integrator=integrator,
                contacts=contacts,
                damping=damping,
                payloads=payloads,
            ),
            progress,
        )
