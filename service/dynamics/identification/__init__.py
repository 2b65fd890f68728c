"""Identification: a robot's inertial parameters and friction from a logged motion.

Topic modules: `parameters` (the 10 numbers per body, pseudo-inertia, to and from a model),
`regressor` (Y(q, v, a) and friction columns), `base_parameters` (the identifiable
combinations), `motion_log` (checks, split, filter), `columns` (robot or payload), `fit`
(weighted least squares and the semidefinite program), `pipeline` (`identify`: all of it).
"""

from service.dynamics.identification.parameters import (
    LAYOUT,
    body_names,
    inertial_parameters,
    pseudo_inertia,
    with_inertial_parameters,
)
from service.dynamics.identification.pipeline import Identification, identify
from service.dynamics.identification.regressor import FRICTION_MODELS, friction_torque, regressor

__all__ = ["FRICTION_MODELS", "LAYOUT", "Identification", "body_names", "friction_torque",
           "identify", "inertial_parameters", "pseudo_inertia", "regressor",
           "with_inertial_parameters"]
