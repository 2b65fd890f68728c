"""Request builder of `simulate`, a rollout of forward dynamics, and its chunks of steps. (The
clients' docstrings describe it.)"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from robodyn import progress, request_options
from robodyn._calls.request import request
from robodyn.arrays import ArrayLike, joint_input
from robodyn.contacts import ContactsLike, ContactTrajectory, contact_options
from robodyn.core import Call
from robodyn.payloads import PayloadsLike
from robodyn.request_options import Integrator
from robodyn.results import Trajectory


def simulate(
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
    payloads: PayloadsLike | None = None,
) -> Call[Trajectory | ContactTrajectory]:
    """Always JSON: a torque schedule is a body field, too big for a binary header. Without
    contacts, more than `progress.CHUNK_STEPS` steps can run in chunks of steps."""
    options = request_options.simulation(dt, steps, tau, controller, integrator)
    call: Call[Trajectory | ContactTrajectory]
    if contacts is not None:  # a contact set holds its frames where the rollout starts
        call = request(
            robot_id,
            "simulate",
            ContactTrajectory.from_json,
            {**options, **contact_options(contacts, damping)},
            payloads=payloads,
            binary_form=False,
            q=q,
            v=v,
        )
        return call
    call = request(
        robot_id,
        "simulate",
        Trajectory.from_json,
        options,
        payloads=payloads,
        binary_form=False,
        q=q,
        v=v,
    )
    if steps <= progress.CHUNK_STEPS:
        return call

    def plan() -> progress.Plan[Trajectory | ContactTrajectory]:
        return _simulation_chunks(
            robot_id,
            q,
            v,
            dt=dt,
            steps=steps,
            tau=tau,
            controller=controller,
            integrator=integrator,
            payloads=payloads,
        )

    return replace(call, chunks=progress.Chunks(steps, "steps", progress.CHUNK_STEPS, plan))


def _simulation_chunks(
    robot_id: str,
    q: ArrayLike,
    v: ArrayLike,
    *,
    dt: float,
    steps: int,
    tau: ArrayLike | Mapping[str, Any] | None,
    controller: Mapping[str, Any] | None,
    integrator: Integrator | None,
    payloads: PayloadsLike | None,
    chunk: int = progress.CHUNK_STEPS,
) -> progress.Plan[Trajectory]:
    """`simulate` as consecutive simulations of at most `chunk` steps, each starting from the
    last state of the one before (see `robodyn.progress.Plan`): the same trajectory, bit for
    bit, as one request (t is dt × step index in both)."""
    schedule = None
    if tau is not None and not isinstance(tau, Mapping):
        torques = joint_input("tau", tau)
        if isinstance(torques, np.ndarray) and torques.ndim == 2:
            schedule = torques  # (steps, nv): τ_k during step k
    parts: list[Trajectory] = []
    done = 0
    while done < steps:
        n = min(chunk, steps - done)
        part_tau = schedule[done : done + n] if schedule is not None else tau
        part: Trajectory = yield (
            simulate(
                robot_id,
                q,
                v,
                dt=dt,
                steps=n,
                tau=part_tau,
                controller=controller,
                integrator=integrator,
                payloads=payloads,
            ),
            done + n,
        )
        parts.append(
            part
            if not parts
            else Trajectory(*(x[..., 1:, :] if x.ndim > part.t.ndim else x[..., 1:] for x in part))
        )
        q, v = part.q[..., -1, :], part.v[..., -1, :]
        done += n
    joined = Trajectory(
        *(
            np.concatenate(xs, axis=-2 if xs[0].ndim > parts[0].t.ndim else -1)
            for xs in zip(*parts, strict=True)
        )
    )
    t = np.broadcast_to(dt * np.arange(steps + 1), joined.t.shape).copy()
    return joined._replace(t=t)
