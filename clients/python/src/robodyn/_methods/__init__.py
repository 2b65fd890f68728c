"""The public methods of `Client` and `AsyncClient`, by topic: a class of blocking methods and
a class of coroutines per topic module, written out with their docstrings. Each method builds
its request with the builder of the same name in `robodyn._calls` and sends it."""

from __future__ import annotations

from robodyn._methods.centroidal import AsyncCentroidalMethods, CentroidalMethods
from robodyn._methods.contacts import AsyncContactMethods, ContactMethods
from robodyn._methods.derivatives import AsyncDerivativeMethods, DerivativeMethods
from robodyn._methods.equation_of_motion import (
    AsyncEquationOfMotionMethods,
    EquationOfMotionMethods,
)
from robodyn._methods.equations import AsyncEquationsMethods, EquationsMethods
from robodyn._methods.frames import AsyncFrameMethods, FrameMethods
from robodyn._methods.health import AsyncHealthMethods, HealthMethods
from robodyn._methods.identification import AsyncIdentificationMethods, IdentificationMethods
from robodyn._methods.lagrangian import AsyncLagrangianMethods, LagrangianMethods
from robodyn._methods.operational_space import AsyncOperationalSpaceMethods, OperationalSpaceMethods
from robodyn._methods.payload_capacity import AsyncPayloadCapacityMethods, PayloadCapacityMethods
from robodyn._methods.robots import AsyncRobotMethods, RobotMethods
from robodyn._methods.simulation import AsyncSimulationMethods, SimulationMethods
from robodyn._methods.trajectories import AsyncTrajectoryMethods, TrajectoryMethods

SYNC = (
    RobotMethods,
    HealthMethods,
    EquationsMethods,
    EquationOfMotionMethods,
    LagrangianMethods,
    FrameMethods,
    OperationalSpaceMethods,
    DerivativeMethods,
    CentroidalMethods,
    SimulationMethods,
    ContactMethods,
    PayloadCapacityMethods,
    TrajectoryMethods,
    IdentificationMethods,
)
"""The method classes `Client` joins (`AsyncClient` joins the `ASYNC` twins, in order)."""
ASYNC = (
    AsyncRobotMethods,
    AsyncHealthMethods,
    AsyncEquationsMethods,
    AsyncEquationOfMotionMethods,
    AsyncLagrangianMethods,
    AsyncFrameMethods,
    AsyncOperationalSpaceMethods,
    AsyncDerivativeMethods,
    AsyncCentroidalMethods,
    AsyncSimulationMethods,
    AsyncContactMethods,
    AsyncPayloadCapacityMethods,
    AsyncTrajectoryMethods,
    AsyncIdentificationMethods,
)

__all__ = ["ASYNC", "SYNC"]
