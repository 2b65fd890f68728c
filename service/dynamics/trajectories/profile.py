"""A timing of a path: the path speed profile that TOPP-RA computes, evaluated exactly.

The profile is the squared path speed x = ṡ² at gridpoints s_0 = 0 < s_1 < … < s_N = L, linear
in s between them, i.e. a constant path acceleration u_i = s̈ = (x_{i+1} − x_i) / (2 Δ_i) on
each interval (Δ_i = s_{i+1} − s_i). On interval i, from its start time t_i:

    ṡ(t) = √x_i + u_i (t − t_i),   s(t) = s_i + √x_i (t − t_i) + ½ u_i (t − t_i)²,
    t_{i+1} − t_i = 2 Δ_i / (√x_i + √x_{i+1})

and the joint motion follows by the chain rule: q = q(s), q̇ = q'(s) ṡ, q̈ = q'(s) s̈ + q''(s) ṡ².
Nothing here is fitted or interpolated: any time t gives the motion the timing defines.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Profile:
    """gridpoints s [N + 1] (units of q) and squared path speeds x [N + 1] ((units of q / s)²,
    x ≥ 0, zero at both ends for a motion from rest to rest)."""

    gridpoints: np.ndarray
    x: np.ndarray

    @property
    def u(self) -> np.ndarray:
        """The path acceleration s̈ on each interval, [N]."""
        return np.diff(self.x) / (2.0 * np.diff(self.gridpoints))

    @property
    def times(self) -> np.ndarray:
        """The time at each gridpoint, [N + 1] (s); t_0 = 0."""
        speed = np.sqrt(self.x)
        return np.concatenate(
            [[0.0], np.cumsum(2.0 * np.diff(self.gridpoints) / (speed[:-1] + speed[1:]))]
        )

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def slowed(self, factor: float) -> Profile:
        """The same path `factor` (≥ 1) times slower: ṡ ÷ factor, s̈ ÷ factor², so joint
        velocities scale by 1/factor and accelerations (and τ − g) by 1/factor²."""
        return Profile(self.gridpoints, self.x / factor**2)

    def at_times(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s, ṡ, s̈) at times t [n] within [0, duration]; a time on a gridpoint takes the path
        acceleration of the interval it starts."""
        grid_t, speed, u = self.times, np.sqrt(self.x), self.u
        i = np.clip(np.searchsorted(grid_t, t, side="right") - 1, 0, len(u) - 1)
        dt = t - grid_t[i]
        sd = np.maximum(speed[i] + u[i] * dt, 0.0)
        s = np.minimum(
            self.gridpoints[i] + speed[i] * dt + 0.5 * u[i] * dt**2, self.gridpoints[i + 1]
        )
        return s, sd, u[i]

    def on_intervals(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s, x = ṡ², s̈) at the points s_i + θ Δ_i of every interval, θ [p] in [0, 1]: arrays
        (N, p). Each interval's end point uses that interval's s̈ (the one-sided value)."""
        s0, dlt, u = self.gridpoints[:-1, None], np.diff(self.gridpoints)[:, None], self.u
        s = s0 + theta[None, :] * dlt
        x = np.maximum(self.x[:-1, None] + 2.0 * theta[None, :] * dlt * u[:, None], 0.0)
        return s, x, np.broadcast_to(u[:, None], s.shape)
