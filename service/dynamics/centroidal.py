"""Centroidal dynamics: the momentum of the whole robot about its centre of mass.

With c the centre of mass (m, world frame), the centroidal momentum is the 6-vector

    h_G = A_G(q) v = [m ċ ; L_G]

— linear momentum m ċ (kg·m/s) then angular momentum about c (kg·m²/s), both in world-aligned
axes — where A_G(q), 6 × nv, is the centroidal momentum matrix (Orin & Goswami), computed by
Pinocchio's centroidal composite rigid-body algorithm (ccrba). Its rate of change equals the
sum of the external wrenches about c (gravity, contacts), which is what makes it the quantity of
balance control. h_G is also the sum over bodies of each body's spatial momentum, moved to c.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from service.dynamics.quantity import Quantity, Results, finite, matrix
from service.registry.robot import Robot
from service.states import States


def centroidal(robot: Robot, s: States) -> Results:
    """h_G = A_G(q) v (N, 6: kg·m/s then kg·m²/s, about the centre of mass, world-aligned),
    A_G(q) (N, 6, nv) and the centre of mass c(q) (N, 3, m, world frame), by ccrba."""
    q, v = s["q"], s["v"]
    n = q.shape[0]
    momentum, momentum_matrix = np.empty((n, 6)), np.empty((n, 6, robot.nv))
    com = np.empty((n, 3))
    with robot.data() as data:
        for i in range(n):
            momentum_matrix[i] = matrix(pin.ccrba(robot.model, data, q[i], v[i]), 6, robot.nv)
            momentum[i] = data.hg.vector
            com[i] = data.com[0]
    return finite(
        "centroidal", momentum=momentum, momentum_matrix=momentum_matrix, center_of_mass=com
    )


CENTROIDAL = (
    Quantity(
        "centroidal",
        ("q", "v"),
        centroidal,
        "Centroidal momentum, centroidal momentum matrix and centre of mass",
        answer_size=lambda r, o, v: 6 + 6 * r.nv + 3,
    ),
)
