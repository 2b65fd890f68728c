"""`GET /v1/robots/{id}/equations`: a robot's equations of motion in explicit form.

The derivation (`service.dynamics.equations`) runs in a child process with a time limit, never
in the serving process, in slots of its own (`ROBODYN_MAX_CONCURRENT_DERIVATIONS`), and each
robot's answer is kept (`EquationsCache`, on `app.state.equations`): a cached answer is served
straight from memory on the event loop; a first request awaits the derivation (run by a thread
of its own), so the loop keeps answering; a refusal for the model's cost is remembered for
every robot with the same numbers.
"""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, Query, Request, Response

from service.api.deps import RegistryDep, served_robot
from service.api.schemas.common import Problem
from service.api.schemas.equations import Equations
from service.api.workers.equations import Printing
from service.api.workers.equations_cache import EquationsCache

router = APIRouter(prefix="/v1/robots", tags=["robots"])


@router.get(
    "/{robot_id}/equations",
    response_model=Equations,
    name="equations",
    responses={
        404: {"model": Problem, "description": "robot_not_found"},
        422: {
            "model": Problem,
            "description": "validation_error: digits, tolerance or form out of range; "
            "unsupported_model: a floating "
            "base, a joint other than revolute or prismatic, more than 6 "
            "moving joints, or a derivation past its time limit (remembered: at once "
            "on every later request for a robot with the same numbers)",
        },
        503: {
            "model": Problem,
            "description": "not_ready, overloaded (no derivation slot free in time, "
            "the machine too busy to finish within the time limit)",
        },
    },
    summary="The equations of motion in explicit form: M(q), C(q, q̇), g(q), the "
    "Christoffel symbols and the energies as SymPy text and LaTeX, with the structure "
    "of M and g",
)
async def equations(
    robot_id: str,
    request: Request,
    registry: RegistryDep,
    digits: Annotated[
        int,
        Query(ge=1, le=17, description="Significant digits of the printed coefficients."),
    ] = 6,
    tolerance: Annotated[
        float,
        Query(
            ge=0,
            le=1,
            allow_inf_nan=False,
            description="Relative: a term whose coefficient is below tolerance × the largest "
            "coefficient of the same quantity is left out (0 keeps every term). "
            "digits=17&tolerance=0 is the exact form.",
        ),
    ] = 1e-9,
    form: Annotated[
        Literal["numeric", "parametric"],
        Query(
            description="numeric: the model's numbers; parametric: linear in the base "
            "inertial parameters p1 … pr (listed under `parameters`)."
        ),
    ] = "numeric",
) -> Response:
    """M(q) q̈ + C(q, q̇) q̇ + g(q) = τ in closed form, derived symbolically from the model's
    own joint placements, axes and inertias (exact decimals), for a fixed-base robot with at
    most 6 moving joints, each revolute or prismatic. Coordinates q1 … qn and velocities
    dq1 … dqn follow the order of `joints`. Readable by default (6 significant digits, terms
    below 1e-9 of their quantity's largest left out, `accuracy` bounding what that changes);
    `form=parametric` writes them in the base inertial parameters. The first request for a
    robot and printing derives them (at most `ROBODYN_EQUATIONS_TIMEOUT_S`), later ones are
    answered from memory (stored models also from disk). See docs/equations.md."""
    robot = await served_robot(registry, robot_id)
    cache: EquationsCache = request.app.state.equations
    printing = Printing(form, digits, tolerance)
    return Response(await cache.answer(robot, printing), media_type="application/json")
