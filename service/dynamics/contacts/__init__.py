"""Rigid contacts, for a contact set given per request (see docs/contacts.md):

- `model`: a contact set as Pinocchio constraint models (cached), its force frames, its
  checks and the singularity test;
- `solve`: proximal iterations to a constraint tolerance, the root least squares of
  contact-consistent inverse dynamics, the work estimate of one evaluation;
- `quantities`: contact-dynamics, contact-inverse-dynamics and impulse-dynamics, and their
  `Quantity` tuple `CONTACTS`;
- `simulation`: the acceleration, torques and drift of `simulate`'s rollouts with contacts.
"""

from service.dynamics.contacts.model import (
    MAX_CONTACTS,
    ContactSet,
    constraint_models,
    constraint_rows,
)
from service.dynamics.contacts.quantities import (
    CONTACTS,
    contact_dynamics,
    contact_inverse_dynamics,
    contact_work,
    impulse_dynamics,
)
from service.dynamics.contacts.simulation import ContactRollout, pd_with_contacts
from service.dynamics.contacts.solve import MAX_DAMPING

__all__ = [
    "CONTACTS",
    "MAX_CONTACTS",
    "MAX_DAMPING",
    "ContactRollout",
    "ContactSet",
    "constraint_models",
    "constraint_rows",
    "contact_dynamics",
    "contact_inverse_dynamics",
    "contact_work",
    "impulse_dynamics",
    "pd_with_contacts",
]
