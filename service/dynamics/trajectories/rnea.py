"""Batch inverse dynamics for the trajectory computations: τ = M(q) a + C(q, v) v + g(q).

Large batches run on every core (Pinocchio's `rneaInParallel`, through
`service.dynamics.parallel`), small ones state by state; both give the same bits.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from service.dynamics import parallel
from service.dynamics.quantity import finite
from service.registry.robot import Robot
from service.states import States

PARALLEL_FROM = 64  # smallest batch computed by the parallel algorithm


def inverse_dynamics(
    robot: Robot, q: np.ndarray, v: np.ndarray, a: np.ndarray, *, checked: bool = True
) -> np.ndarray:
    """τ (N, nv) for states q (N, nq, Pinocchio's order), v and a (N, nv), in SI units;
    NonFiniteResult where τ is not finite (`checked` False: the caller checks it)."""
    q, v, a = (np.ascontiguousarray(x, dtype=np.float64) for x in (q, v, a))
    n = q.shape[0]
    if n >= PARALLEL_FROM:
        states = States(arrays={"q": q, "v": v, "a": a}, batched=True)
        out = parallel.inverse_dynamics(robot, states)["tau"]
    else:
        out = np.empty((n, robot.nv))
        with robot.data() as data:
            for i in range(n):
                out[i] = pin.rnea(robot.model, data, q[i], v[i], a[i])
    return finite("the motion's torques", tau=out)["tau"] if checked else out


def path_coefficients(
    robot: Robot, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The torque along a path q(s) as a function of the path speed and acceleration:

        τ(s) = A(s) s̈ + B(s) ṡ² + C(s),   A = M q',  B = M q'' + C(q, q') q',  C = g(q)

    (the chain rule q̇ = q' ṡ, q̈ = q' s̈ + q'' ṡ² put into τ = M q̈ + C(q, q̇) q̇ + g, whose
    velocity term is quadratic in q̇). From three RNEA batches at the points q = q(s) (n, nq)
    with path derivatives dq = q'(s), ddq = q''(s) (n, nv). Each returned array is (n, nv)."""
    n = q.shape[0]
    zeros = np.zeros_like(dq)
    tau = inverse_dynamics(
        robot,
        np.concatenate([q, q, q]),
        np.concatenate([zeros, zeros, dq]),
        np.concatenate([zeros, dq, ddq]),
    )
    gravity = tau[:n]
    return tau[n : 2 * n] - gravity, tau[2 * n :] - gravity, gravity
