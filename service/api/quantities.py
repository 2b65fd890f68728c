"""The one table of the dynamics quantities' schemas: each `service.dynamics.Quantity` → its
(request, answer) pydantic models.

This is the only place of the API that names a quantity. The routes, their OpenAPI
descriptions, the binary form and the stream are derived from `SPECS`; the request models
gain the options every computing route takes (`with_common_options`). At import, the table is
checked against `service.dynamics.QUANTITIES`: every quantity has exactly one request and one
answer model, the request has a field for each joint-space input, and each joint-space answer
(`Quantity.joint_answers`) is typed as an array-or-object-keyed-by-name (`JointVector`).
"""

from __future__ import annotations

from dataclasses import dataclass

from pydantic import BaseModel

from service import dynamics
from service.api.schemas.centroidal import CentroidalAnswer
from service.api.schemas.common import (
    JointVector,
    OptionalVRequest,
    QRequest,
    QVARequest,
    QVRequest,
    QVTauRequest,
    with_common_options,
)
from service.api.schemas.contacts import (
    ContactDynamicsAnswer,
    ContactDynamicsRequest,
    ContactInverseDynamicsAnswer,
    ContactInverseDynamicsRequest,
    ImpulseDynamicsAnswer,
    ImpulseDynamicsRequest,
)
from service.api.schemas.derivatives import (
    ForwardDynamicsDerivativesAnswer,
    InverseDynamicsDerivativesAnswer,
)
from service.api.schemas.equation_of_motion import (
    CoriolisAnswer,
    ForwardDynamicsAnswer,
    ForwardDynamicsRequest,
    GravityAnswer,
    InverseDynamicsAnswer,
    InverseDynamicsRequest,
    MassMatrixAnswer,
    NonlinearEffectsAnswer,
)
from service.api.schemas.frames import JacobianAnswer, JacobianRequest
from service.api.schemas.identification import RegressorAnswer
from service.api.schemas.lagrangian import CenterOfMassAnswer, EnergyAnswer, MassMatrixInverseAnswer
from service.api.schemas.operational_space import OperationalSpaceAnswer, OperationalSpaceRequest
from service.api.schemas.payload_capacity import PayloadCapacityAnswer, PayloadCapacityRequest
from service.api.schemas.placements import FramePlacementsAnswer, FramePlacementsRequest
from service.api.schemas.simulation import SimulateAnswer, SimulateRequest
from service.api.schemas.trajectories import (
    RetimeAnswer,
    RetimeRequest,
    TrajectoryCheckAnswer,
    TrajectoryCheckRequest,
)


@dataclass(frozen=True)
class Spec:
    """A quantity as the API serves it: the physics and its request and answer models."""

    quantity: dynamics.Quantity
    request: type[BaseModel]
    answer: type[BaseModel]


_SCHEMAS: dict[str, tuple[type[BaseModel], type[BaseModel]]] = {
    "mass-matrix": (QRequest, MassMatrixAnswer),
    "gravity": (QRequest, GravityAnswer),
    "coriolis": (QVRequest, CoriolisAnswer),
    "nonlinear-effects": (QVRequest, NonlinearEffectsAnswer),
    "inverse-dynamics": (InverseDynamicsRequest, InverseDynamicsAnswer),
    "forward-dynamics": (ForwardDynamicsRequest, ForwardDynamicsAnswer),
    "mass-matrix-inverse": (QRequest, MassMatrixInverseAnswer),
    "energy": (QVRequest, EnergyAnswer),
    "center-of-mass": (OptionalVRequest, CenterOfMassAnswer),
    "jacobian": (JacobianRequest, JacobianAnswer),
    "operational-space": (OperationalSpaceRequest, OperationalSpaceAnswer),
    "inverse-dynamics-derivatives": (QVARequest, InverseDynamicsDerivativesAnswer),
    "forward-dynamics-derivatives": (QVTauRequest, ForwardDynamicsDerivativesAnswer),
    "centroidal": (QVRequest, CentroidalAnswer),
    "simulate": (SimulateRequest, SimulateAnswer),
    "contact-dynamics": (ContactDynamicsRequest, ContactDynamicsAnswer),
    "contact-inverse-dynamics": (ContactInverseDynamicsRequest, ContactInverseDynamicsAnswer),
    "impulse-dynamics": (ImpulseDynamicsRequest, ImpulseDynamicsAnswer),
    "frame-placements": (FramePlacementsRequest, FramePlacementsAnswer),
    "payload-capacity": (PayloadCapacityRequest, PayloadCapacityAnswer),
    "trajectory-check": (TrajectoryCheckRequest, TrajectoryCheckAnswer),
    "retime": (RetimeRequest, RetimeAnswer),
    "regressor": (QVARequest, RegressorAnswer),
}


def _check(spec: Spec) -> Spec:
    """`spec`, or an AssertionError naming what its models lack."""
    name, fields = spec.quantity.name, spec.request.model_fields
    for array in (*spec.quantity.inputs, *spec.quantity.optional):
        assert array in fields, f"{name}: the request model has no field {array!r}"
    for answer in spec.quantity.joint_answers:
        field = spec.answer.model_fields.get(answer)
        assert field is not None and field.annotation == JointVector, (
            f"{name}: the answer {answer!r} is keyed by joint name on request; type it "
            "JointVector in the answer model"
        )
    return spec


_missing = set(dynamics.QUANTITIES).symmetric_difference(_SCHEMAS)
assert not _missing, f"quantities and schemas differ: {sorted(_missing)}"

SPECS: dict[str, Spec] = {
    name: _check(Spec(quantity, with_common_options(_SCHEMAS[name][0]), _SCHEMAS[name][1]))
    for name, quantity in dynamics.QUANTITIES.items()
}
"""Every quantity by name, in the order of `service.dynamics.QUANTITIES`."""
