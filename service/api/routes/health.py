"""Health and metrics routes, outside /v1."""

from __future__ import annotations

from fastapi import APIRouter, Request, Response
from fastapi.responses import PlainTextResponse
from prometheus_client import CONTENT_TYPE_LATEST, generate_latest

from service.api.encoding.answers import JSONAnswer
from service.api.problems.handlers import problem
from service.api.schemas.common import Problem
from service.api.schemas.health import Liveness, Readiness

router = APIRouter(tags=["operations"])


@router.get(
    "/health/live",
    response_model=Liveness,
    name="health_live",
    summary="200 whenever the process answers",
)
async def live() -> Response:
    return JSONAnswer({"status": "ok"})


@router.get(
    "/health/ready",
    response_model=Readiness,
    name="health_ready",
    responses={503: {"model": Problem, "description": "not_ready"}},
    summary="200 once the catalog is loaded; 503 before",
)
async def ready(request: Request) -> Response:
    registry = request.app.state.registry
    if not registry.ready:
        return problem(
            "not_ready", "Not ready", "the robot catalog is still loading", {"Retry-After": "1"}
        )
    return JSONAnswer(
        {
            "status": "ready",
            "robots": len(registry.catalog),
            "unavailable": sorted(registry.catalog_failures),
        }
    )


@router.get(
    "/metrics",
    response_class=PlainTextResponse,
    responses={
        200: {
            "description": "Prometheus text exposition format "
            f"({CONTENT_TYPE_LATEST}): request counts, latencies, compute "
            "time and batch sizes by route, robot and quantity"
        }
    },
    summary="Prometheus metrics: requests and latency by route and robot",
)
async def metrics(request: Request) -> Response:
    return Response(
        generate_latest(request.app.state.metrics.registry), media_type=CONTENT_TYPE_LATEST
    )
