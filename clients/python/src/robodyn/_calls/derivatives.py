"""Request builders of the derivatives of inverse and forward dynamics. (The clients'
docstrings describe them.)"""

from __future__ import annotations

from robodyn._calls.request import request
from robodyn.arrays import ArrayLike
from robodyn.core import Call
from robodyn.payloads import PayloadsLike
from robodyn.results import ForwardDynamicsDerivatives, InverseDynamicsDerivatives


def inverse_dynamics_derivatives(
    robot_id: str, q: ArrayLike, v: ArrayLike, a: ArrayLike, *, payloads: PayloadsLike | None = None
) -> Call[InverseDynamicsDerivatives]:
    return request(
        robot_id,
        "inverse-dynamics-derivatives",
        InverseDynamicsDerivatives.from_json,
        payloads=payloads,
        q=q,
        v=v,
        a=a,
    )


def forward_dynamics_derivatives(
    robot_id: str,
    q: ArrayLike,
    v: ArrayLike,
    tau: ArrayLike,
    *,
    payloads: PayloadsLike | None = None,
) -> Call[ForwardDynamicsDerivatives]:
    return request(
        robot_id,
        "forward-dynamics-derivatives",
        ForwardDynamicsDerivatives.from_json,
        payloads=payloads,
        q=q,
        v=v,
        tau=tau,
    )
