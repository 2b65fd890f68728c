"""The model check: `GET /v1/robots/{id}/model-check` (the inertias a description claims,
against physics and the link's own geometry), computed in a child process
(`service.api.workers.model_check`) and kept per robot."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Response
from starlette.concurrency import run_in_threadpool

from service.api.deps import RegistryDep
from service.api.encoding.answers import JSONAnswer
from service.api.schemas.common import Problem
from service.api.schemas.model_check import ModelCheck
from service.api.workers.model_check import model_check_answer

router = APIRouter(prefix="/v1/robots", tags=["robots"])

_PROBLEMS: dict[int | str, dict[str, Any]] = {
    404: {"model": Problem, "description": "robot_not_found"},
    422: {"model": Problem, "description": "unsupported_model (the check went past its limits)"},
    503: {"model": Problem, "description": "overloaded"},
}


@router.get(
    "/{robot_id}/model-check",
    response_model=ModelCheck,
    responses=_PROBLEMS,
    summary="The inertias the description claims, against physics and each link's geometry",
)
async def model_check(robot_id: str, registry: RegistryDep) -> Response:
    """Errors no rigid body has (negative principal moment, triangle inequality, inertia
    without mass; with a power-of-ten correction where one explains it), warnings for what is
    possible but rarely meant (point mass or massless link with a shape, implausible density,
    centre of mass outside the shape, inertia 10× off its shape's, left/right twins that
    disagree, open meshes), and each link's mass properties beside its geometry's (collision,
    else visual; meshes by the divergence theorem). Catalog robots as loaded, uploads and
    variants (with their repairs)."""
    return JSONAnswer(await run_in_threadpool(model_check_answer, registry, robot_id))
