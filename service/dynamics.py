"""The terms of the joint-space equation of motion, M(q) a + C(q, v) v + g(q) = τ.

One function per physical quantity. Each takes a `Robot` and validated `States` (arrays of shape
(N, n), see `service.states`), borrows its own `pin.Data` for the computation, and returns arrays
with the batch axis first. Units are SI: q in rad (revolute) or m (prismatic), v in rad/s or m/s,
a in rad/s² or m/s², τ in N·m or N; M in kg·m² (or kg), g and C v in the units of τ.

A non-finite result (e.g. forward dynamics of a robot with a massless moving body) raises
`NonFiniteResult`: JSON cannot carry it, and it is never silently returned.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from service.errors import NonFiniteResult
from service.registry.robot import Robot
from service.states import States


def _finite(quantity: str, **results: np.ndarray) -> dict[str, np.ndarray]:
    for name, value in results.items():
        if not np.all(np.isfinite(value)):
            raise NonFiniteResult(f"{quantity}: the computed {name} is not finite for these "
                                  "inputs (is a moving body massless, or an input extreme?)")
    return results


def _symmetric(upper: np.ndarray) -> np.ndarray:
    # CRBA fills the upper triangle; the lower one is not guaranteed to be up to date.
    return np.triu(upper) + np.triu(upper, 1).T


def mass_matrix(robot: Robot, s: States) -> dict[str, np.ndarray]:
    """M(q), the joint-space inertia matrix (CRBA), shape (N, nv, nv), symmetric positive
    definite; the kinetic energy is T = ½ vᵀ M v. Includes the armature on its diagonal."""
    q = s["q"]
    out = np.empty((q.shape[0], robot.nv, robot.nv))
    with robot.data() as data:
        for i in range(q.shape[0]):
            out[i] = _symmetric(pin.crba(robot.model, data, q[i]))
    return _finite("mass-matrix", mass_matrix=out)


def gravity(robot: Robot, s: States) -> dict[str, np.ndarray]:
    """g(q), the generalized gravity torques (gradient of the potential energy), (N, nv)."""
    q = s["q"]
    out = np.empty((q.shape[0], robot.nv))
    with robot.data() as data:
        for i in range(q.shape[0]):
            out[i] = pin.computeGeneralizedGravity(robot.model, data, q[i])
    return _finite("gravity", gravity=out)


def coriolis(robot: Robot, s: States) -> dict[str, np.ndarray]:
    """C(q, v), the Coriolis/centrifugal matrix with Ṁ = C + Cᵀ, (N, nv, nv), and the forces
    C(q, v) v, (N, nv)."""
    q, v = s["q"], s["v"]
    n = q.shape[0]
    C = np.empty((n, robot.nv, robot.nv))
    with robot.data() as data:
        for i in range(n):
            C[i] = pin.computeCoriolisMatrix(robot.model, data, q[i], v[i])
    Cv = np.einsum("nij,nj->ni", C, v)
    return _finite("coriolis", coriolis_matrix=C, coriolis_forces=Cv)


def nonlinear_effects(robot: Robot, s: States) -> dict[str, np.ndarray]:
    """h(q, v) = C(q, v) v + g(q) (Pinocchio's nonlinear effects include gravity), (N, nv)."""
    q, v = s["q"], s["v"]
    out = np.empty((q.shape[0], robot.nv))
    with robot.data() as data:
        for i in range(q.shape[0]):
            out[i] = pin.nonLinearEffects(robot.model, data, q[i], v[i])
    return _finite("nonlinear-effects", nonlinear_effects=out)


def inverse_dynamics(robot: Robot, s: States) -> dict[str, np.ndarray]:
    """τ = M(q) a + C(q, v) v + g(q) by the recursive Newton–Euler algorithm, (N, nv)."""
    q, v, a = s["q"], s["v"], s["a"]
    out = np.empty((q.shape[0], robot.nv))
    with robot.data() as data:
        for i in range(q.shape[0]):
            out[i] = pin.rnea(robot.model, data, q[i], v[i], a[i])
    return _finite("inverse-dynamics", tau=out)


def forward_dynamics(robot: Robot, s: States) -> dict[str, np.ndarray]:
    """a = M(q)⁻¹ (τ − C(q, v) v − g(q)) by the articulated-body algorithm, (N, nv)."""
    q, v, tau = s["q"], s["v"], s["tau"]
    out = np.empty((q.shape[0], robot.nv))
    with robot.data() as data:
        for i in range(q.shape[0]):
            out[i] = pin.aba(robot.model, data, q[i], v[i], tau[i])
    return _finite("forward-dynamics", a=out)


@dataclass(frozen=True)
class Quantity:
    """A dynamics endpoint: its path name, joint-space inputs and computing function."""

    path: str
    inputs: tuple[str, ...]
    compute: Callable[[Robot, States], dict[str, np.ndarray]]
    summary: str


QUANTITIES: dict[str, Quantity] = {
    q.path: q for q in (
        Quantity("mass-matrix", ("q",), mass_matrix, "Mass matrix M(q)"),
        Quantity("gravity", ("q",), gravity, "Gravity vector g(q)"),
        Quantity("coriolis", ("q", "v"), coriolis, "Coriolis matrix C(q, v) and forces C v"),
        Quantity("nonlinear-effects", ("q", "v"), nonlinear_effects,
                 "Nonlinear effects C(q, v) v + g(q)"),
        Quantity("inverse-dynamics", ("q", "v", "a"), inverse_dynamics,
                 "Inverse dynamics τ = M a + C v + g (RNEA)"),
        Quantity("forward-dynamics", ("q", "v", "tau"), forward_dynamics,
                 "Forward dynamics a = M⁻¹ (τ − C v − g) (ABA)"),
    )
}


def compute(robot: Robot, quantity: str, s: States) -> dict[str, Any]:
    """Run one quantity and drop the batch axis for a single-state request."""
    results = QUANTITIES[quantity].compute(robot, s)
    return {name: s.unbatch(value) for name, value in results.items()}
