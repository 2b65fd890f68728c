"""How far a quantity that is known at evenly spaced points of an interval can go between them.

On an interval where f is smooth (here: inside one TOPP-RA interval, where the path is one
cubic polynomial and the path acceleration one constant), f between two neighbouring points
j, j + 1 a step h apart exceeds max(f_j, f_{j+1}) by at most h² max|f''| / 8 (the error bound of
linear interpolation). h² f'' is estimated by the second differences
f_{j−1} − 2 f_j + f_{j+1} of the points themselves, their largest magnitude over the interval
standing for max|f''| h². So the upper envelope of f on the interval is taken as

    max_j f_j + max_j |f_{j−1} − 2 f_j + f_{j+1}| / 8

(and the lower one likewise). It is an estimate, not a proof: it is exact for quadratics and
holds where f'' varies little across the interval, which a fine enough grid ensures.
"""

from __future__ import annotations

import numpy as np


def curvature_margin(f: np.ndarray) -> np.ndarray:
    """max |second difference| / 8 over axis 1 of f (N, p, ...) with p ≥ 3: (N, ...)."""
    second = f[:, :-2] - 2.0 * f[:, 1:-1] + f[:, 2:]
    margin: np.ndarray = np.abs(second).max(axis=1) / 8.0
    return margin


def upper_envelope(f: np.ndarray) -> np.ndarray:
    """The estimated maximum of f over each interval: f (N, p, ...) → (N, ...)."""
    upper: np.ndarray = f.max(axis=1) + curvature_margin(f)
    return upper


def lower_envelope(f: np.ndarray) -> np.ndarray:
    """The estimated minimum of f over each interval: f (N, p, ...) → (N, ...)."""
    lower: np.ndarray = f.min(axis=1) - curvature_margin(f)
    return lower
