"""Identification: a robot's inertial parameters and friction from a logged motion.

Topic modules: `parameters` (the 10 numbers per body, pseudo-inertia, to and from a model),
`regressor` (Y(q, v, a) and friction columns; the `regressor` quantity), `base_parameters`
(the identifiable combinations), `motion_log` (checks, split, filter), `columns` (robot or
payload), `fit` (weighted least squares and the semidefinite program), `pipeline`
(`identify`: all of it). The service runs `identify` in a worker process with a time limit
(`service.api.workers.identification`).

`identify` and `Identification` are imported on first use (the fit needs scipy's signal
processing and cvxpy, seconds of imports the serving process does not pay until then).
"""

from typing import Any

from service.dynamics.identification.parameters import (
    LAYOUT,
    body_names,
    inertial_parameters,
    pseudo_inertia,
    with_inertial_parameters,
)
from service.dynamics.identification.regressor import (
    FRICTION_MODELS,
    REGRESSOR,
    friction_torque,
    regressor,
)

__all__ = [
    "FRICTION_MODELS",
    "LAYOUT",
    "REGRESSOR",
    "Identification",
    "body_names",
    "friction_torque",
    "identify",
    "inertial_parameters",
    "pseudo_inertia",
    "regressor",
    "with_inertial_parameters",
]


def __getattr__(name: str) -> Any:
    if name in ("identify", "Identification"):
        from service.dynamics.identification import pipeline

        return getattr(pipeline, name)
    raise AttributeError(name)
