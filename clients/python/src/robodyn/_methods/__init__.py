"""The public methods of `Client` and `AsyncClient`, by topic: a class of blocking methods and
a class of coroutines per topic module, written out with their docstrings. Each method builds
its request with the builder of the same name in `robodyn._calls` and sends it."""

from __future__ import annotations

from robodyn._methods.beyond import AsyncBeyondMethods, BeyondMethods
from robodyn._methods.contacts import AsyncContactMethods, ContactMethods
from robodyn._methods.dynamics import AsyncDynamicsMethods, DynamicsMethods
from robodyn._methods.identification import AsyncIdentificationMethods, IdentificationMethods
from robodyn._methods.robots import AsyncRobotMethods, RobotMethods
from robodyn._methods.trajectories import AsyncTrajectoryMethods, TrajectoryMethods

SYNC = (
    RobotMethods,
    DynamicsMethods,
    BeyondMethods,
    ContactMethods,
    TrajectoryMethods,
    IdentificationMethods,
)
"""The method classes `Client` joins (`AsyncClient` joins the `ASYNC` twins, in order)."""
ASYNC = (
    AsyncRobotMethods,
    AsyncDynamicsMethods,
    AsyncBeyondMethods,
    AsyncContactMethods,
    AsyncTrajectoryMethods,
    AsyncIdentificationMethods,
)

__all__ = ["ASYNC", "SYNC"]
