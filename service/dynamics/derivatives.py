"""Analytical derivatives of inverse and forward dynamics (Carpentier & Mansard, RSS 2018).

Derivatives are taken on the tangent space of the configuration manifold: ∂/∂q has nv columns
and means the derivative along q ⊕ δq = `pin.integrate(model, q, δq)`, so that

    τ(q ⊕ δq, v + δv, a + δa) ≈ τ + ∂τ/∂q δq + ∂τ/∂v δv + ∂τ/∂a δa.

For a robot without free-flyer, spherical, planar or continuous joints q ⊕ δq = q + δq and these
are the ordinary partial derivatives. For a free-flyer base, δq's first 6 entries are a linear
then angular displacement in the base frame (the same coordinates as v). Every matrix is
(N, nv, nv); units are those of the output over those of the input (e.g. ∂τ/∂q in N·m/rad).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from service.dynamics.quantity import Quantity, Results, finite, matrix, mirror_upper
from service.registry.robot import Robot
from service.states import States


def inverse_dynamics_derivatives(robot: Robot, s: States) -> Results:
    """∂τ/∂q, ∂τ/∂v and ∂τ/∂a = M(q) of τ = M(q) a + C(q, v) v + g(q) (analytical RNEA
    derivatives), each (N, nv, nv), with ∂/∂q on the tangent space (q ⊕ δq)."""
    q, v, a = s["q"], s["v"], s["a"]
    n, nv = q.shape[0], robot.nv
    dq, dv, da = np.empty((n, nv, nv)), np.empty((n, nv, nv)), np.empty((n, nv, nv))
    with robot.data() as data:
        for i in range(n):
            dq[i], dv[i], da[i] = (
                matrix(d, nv, nv)
                for d in pin.computeRNEADerivatives(robot.model, data, q[i], v[i], a[i])
            )
    mirror_upper(da)
    return finite("inverse-dynamics-derivatives", dtau_dq=dq, dtau_dv=dv, dtau_da=da)


def forward_dynamics_derivatives(robot: Robot, s: States) -> Results:
    """∂a/∂q, ∂a/∂v and ∂a/∂τ = M(q)⁻¹ of a = M(q)⁻¹ (τ − C(q, v) v − g(q)) (analytical ABA
    derivatives), each (N, nv, nv), with ∂/∂q on the tangent space (q ⊕ δq)."""
    q, v, tau = s["q"], s["v"], s["tau"]
    n, nv = q.shape[0], robot.nv
    dq, dv, dtau = np.empty((n, nv, nv)), np.empty((n, nv, nv)), np.empty((n, nv, nv))
    with robot.data() as data:
        for i in range(n):
            dq[i], dv[i], dtau[i] = (
                matrix(d, nv, nv)
                for d in pin.computeABADerivatives(robot.model, data, q[i], v[i], tau[i])
            )
    mirror_upper(dtau)
    return finite("forward-dynamics-derivatives", da_dq=dq, da_dv=dv, da_dtau=dtau)


DERIVATIVES = (
    Quantity(
        "inverse-dynamics-derivatives",
        ("q", "v", "a"),
        inverse_dynamics_derivatives,
        "Derivatives of inverse dynamics ∂τ/∂q, ∂τ/∂v, ∂τ/∂a = M",
        answer_size=lambda r, o, v: 3 * r.nv * r.nv,
    ),
    Quantity(
        "forward-dynamics-derivatives",
        ("q", "v", "tau"),
        forward_dynamics_derivatives,
        "Derivatives of forward dynamics ∂a/∂q, ∂a/∂v, ∂a/∂τ = M⁻¹",
        answer_size=lambda r, o, v: 3 * r.nv * r.nv,
    ),
)
