"""The application factory: settings → registry → FastAPI app with routers and handlers."""

from __future__ import annotations

import inspect
import logging
import threading
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI

from service import __version__
from service.api import dynamics as dynamics_routes
from service.api import health, robots
from service.api.observability import BodyLimitMiddleware, Metrics, ObservabilityMiddleware
from service.api.problems import install_problem_handlers
from service.logs import configure_logging
from service.registry import Registry
from service.settings import Settings

log = logging.getLogger("robodyn")

DESCRIPTION = """Rigid-body dynamics of any robot over HTTP, on Pinocchio: the terms of
M(q) a + C(q, v) v + g(q) = τ for one joint state or a batch. Units are SI. Errors are
RFC 9457 problem+json with a stable `code`."""


def create_app(settings: Settings | None = None, registry: Registry | None = None) -> FastAPI:
    """Build the app. With an injected `registry` (tests) nothing is loaded at start-up;
    otherwise the lifespan loads the catalog in the background and /health/ready turns 200."""
    settings = settings or Settings()
    injected = registry is not None
    registry = registry or Registry(settings.data_dir, settings.catalog_names(),
                                    settings.build_timeout_s)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        if not injected and not registry.ready:
            threading.Thread(target=registry.load, name="catalog-loader", daemon=True).start()
        yield

    options: dict[str, Any] = {}
    if "strict_content_type" in inspect.signature(FastAPI.__init__).parameters:
        options["strict_content_type"] = False  # a JSON body is read as JSON whatever its label
    app = FastAPI(title="robodyn", version=__version__, description=DESCRIPTION,
                  lifespan=lifespan, **options)
    app.state.settings = settings
    app.state.registry = registry
    app.state.api_keys = [k.encode() for k in settings.api_key_list()]
    app.state.metrics = Metrics()
    app.state.batches_in_flight = 0
    install_problem_handlers(app)
    app.include_router(health.router)
    app.include_router(robots.router)
    app.include_router(dynamics_routes.router)
    app.add_middleware(BodyLimitMiddleware, limit=settings.max_body_bytes)
    app.add_middleware(ObservabilityMiddleware, metrics=app.state.metrics,
                       catalog_ids=lambda: registry.catalog)  # outermost: sees every answer
    return app


def app_from_environment() -> FastAPI:
    """Factory used by `python -m service` (also in each worker process, which is why the
    logging is configured here too)."""
    settings = Settings()
    configure_logging(settings.log_level)
    return create_app(settings)
