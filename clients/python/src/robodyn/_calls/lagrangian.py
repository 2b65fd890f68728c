"""Request builders of the Lagrangian quantities: M(q)⁻¹, the energies and the centre of mass.
(The clients' docstrings describe them.)"""

from __future__ import annotations

import numpy as np

from robodyn._calls.request import array, request
from robodyn.arrays import ArrayLike
from robodyn.core import Call
from robodyn.payloads import PayloadsLike
from robodyn.results import CenterOfMass, Energy


def mass_matrix_inverse(
    robot_id: str, q: ArrayLike, *, payloads: PayloadsLike | None = None
) -> Call[np.ndarray]:
    return request(
        robot_id, "mass-matrix-inverse", array("mass_matrix_inverse", 2), payloads=payloads, q=q
    )


def energy(
    robot_id: str, q: ArrayLike, v: ArrayLike, *, payloads: PayloadsLike | None = None
) -> Call[Energy]:
    return request(robot_id, "energy", Energy.from_json, payloads=payloads, q=q, v=v)


def center_of_mass(
    robot_id: str, q: ArrayLike, v: ArrayLike | None = None, *, payloads: PayloadsLike | None = None
) -> Call[CenterOfMass]:
    return request(
        robot_id,
        "center-of-mass",
        CenterOfMass.from_json,
        payloads=payloads,
        optional=("v",),
        q=q,
        v=v,
    )
