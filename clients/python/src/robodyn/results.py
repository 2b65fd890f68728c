"""Named results of the quantities that answer several arrays (tuples: they also unpack)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class InverseDynamicsDerivatives(NamedTuple):
    """∂τ/∂q, ∂τ/∂v, ∂τ/∂a = M(q), each (nv, nv) (∂/∂q on the tangent space: nv columns)."""

    dtau_dq: np.ndarray
    dtau_dv: np.ndarray
    dtau_da: np.ndarray


class ForwardDynamicsDerivatives(NamedTuple):
    """∂a/∂q, ∂a/∂v, ∂a/∂τ = M(q)⁻¹, each (nv, nv) (∂/∂q on the tangent space)."""

    da_dq: np.ndarray
    da_dv: np.ndarray
    da_dtau: np.ndarray


class Centroidal(NamedTuple):
    """Centroidal momentum (6: kg·m/s then kg·m²/s, about the centre of mass, world-aligned),
    the centroidal momentum matrix (6, nv) and the centre of mass (3, m, world frame)."""

    momentum: np.ndarray
    momentum_matrix: np.ndarray
    center_of_mass: np.ndarray


class Trajectory(NamedTuple):
    """A simulated trajectory of steps + 1 samples: times t (s), configurations q
    (steps + 1, nq), velocities v (steps + 1, nv) and the mechanical energy T + U (J); with a
    leading axis N for a batch of initial states."""

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    mechanical_energy: np.ndarray
