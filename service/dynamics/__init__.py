"""Dynamics quantities: one function per physical quantity, and the table of endpoints.

Each topic module contributes a tuple of `Quantity`; `QUANTITIES` maps every quantity name to
its quantity. Only this package and `service.registry` import Pinocchio.
"""

from service.dynamics.centroidal import CENTROIDAL
from service.dynamics.contacts import CONTACTS
from service.dynamics.derivatives import DERIVATIVES
from service.dynamics.equation_of_motion import EQUATION_OF_MOTION
from service.dynamics.frames import FRAMES
from service.dynamics.identification.regressor import REGRESSOR
from service.dynamics.lagrangian import LAGRANGIAN
from service.dynamics.operational_space import OPERATIONAL_SPACE
from service.dynamics.payload_capacity import PAYLOAD_CAPACITY
from service.dynamics.placements import PLACEMENTS
from service.dynamics.quantity import (
    Quantity,
    Results,
    finite,
    finite_from_answer,
    has_parallel_form,
    run,
)
from service.dynamics.simulation import SIMULATION
from service.dynamics.trajectories.quantities import TRAJECTORIES

QUANTITIES: dict[str, Quantity] = {
    q.name: q
    for q in (
        *EQUATION_OF_MOTION,
        *LAGRANGIAN,
        *FRAMES,
        *OPERATIONAL_SPACE,
        *DERIVATIVES,
        *CENTROIDAL,
        *SIMULATION,
        *CONTACTS,
        *PLACEMENTS,
        *PAYLOAD_CAPACITY,
        *TRAJECTORIES,
        *REGRESSOR,
    )
}

__all__ = [
    "QUANTITIES",
    "Quantity",
    "Results",
    "finite",
    "finite_from_answer",
    "has_parallel_form",
    "run",
]
