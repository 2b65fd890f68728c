"""The application factory: settings → registry → FastAPI app with routers and handlers."""

from __future__ import annotations

import asyncio
import inspect
import logging
import os
import threading
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from fastapi import Depends, FastAPI

from service import __version__, heap, processes, unpin_this_thread
from service.api.activity import Activity
from service.api.deps import require_api_key_for_all
from service.api.encoding.in_flight import AnswerBytesInFlight
from service.api.encoding.shared_bodies import sweep_periodically
from service.api.middleware.api_keys import KeyBeforeBody
from service.api.middleware.body_limit import BodyLimitMiddleware
from service.api.middleware.fast_path import DynamicsFastPath
from service.api.middleware.head import HeadAsGet
from service.api.middleware.observability import Metrics, ObservabilityMiddleware
from service.api.problems.handlers import install_problem_handlers
from service.api.problems.openapi import operation_id, problem_openapi
from service.api.routes import dynamics as dynamics_routes
from service.api.routes import (
    equations,
    health,
    identification,
    model_check,
    pages,
    robots,
    stream,
    visuals,
)
from service.api.workers.batch_split import BatchSplit
from service.api.workers.equations_cache import EquationsCache
from service.logs import capture_native_stderr, configure_logging
from service.registry import Registry, data_pool
from service.registry.build_slots import DERIVATIONS, BuildSlots, build_slot_count
from service.registry.urdf_check import Limits
from service.segments import SegmentDirectory, segment_directory_of
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
    data_pool.BUDGET.limit_bytes = settings.data_pool_mb * 1024 * 1024
    heap.retain_freed_memory(settings.heap_retain_mb)  # process-wide, like the Data budget
    registry = registry or Registry(
        settings.data_dir,
        settings.catalog_names(),
        settings.build_timeout_s,
        limits=Limits(**settings.model_limits()),
        build_limits=settings.build_limits(),
        build_slots=BuildSlots(
            build_slot_count(settings.max_concurrent_builds), settings.build_queue_timeout_s
        ),
    )

    segments = (
        SegmentDirectory(segment_directory_of(settings.unix_socket))
        if settings.unix_socket is not None
        else None
    )

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        if not injected and not registry.ready:
            threading.Thread(target=registry.load, name="catalog-loader", daemon=True).start()
        # The OpenAPI document (~0.5 s to build) is read by the first validation error, for
        # close-match suggestions: built now, not on the event loop under that request.
        app.openapi()
        sweeper = None
        if segments is not None:  # the shared-memory segments of clients on the Unix socket
            segments.create()
            sweeper = asyncio.create_task(sweep_periodically(segments))
        yield
        if sweeper is not None:
            sweeper.cancel()
        if segments is not None:  # this process's answer files (the directory: __main__'s)
            segments.answers.close()
        if app.state.batch_split is not None:  # its helpers and their shared files
            app.state.batch_split.close()
        worker = getattr(app.state, "identification", None)
        if worker is not None:  # the identification worker process, if one was started
            worker.close()
        # every child process (builders, the JSON helper, ...), the forkserver and
        # multiprocessing's resource tracker: the server leaves no process behind
        processes.shutdown()

    options: dict[str, Any] = {}
    accepted = inspect.signature(FastAPI.__init__).parameters  # options of newer FastAPI only
    if "strict_content_type" in accepted:
        options["strict_content_type"] = False  # a JSON body is read as JSON whatever its label
    if "telemetry" in accepted:
        # FastAPI's OpenTelemetry layer asked the environment and the global providers on
        # every request (~20 µs, a tenth of a single-state answer); robodyn exports its own
        # Prometheus metrics (service/api/middleware/observability.py).
        options["telemetry"] = {"tracing": False, "metrics": False, "logs": False}
    # /docs is served by service.api.routes.pages from local assets (FastAPI's default loads a CDN);
    # ReDoc is off, as its page would load its script and fonts from the internet.
    app = FastAPI(
        title="robodyn",
        version=__version__,
        description=DESCRIPTION,
        lifespan=lifespan,
        docs_url=None,
        redoc_url=None,
        generate_unique_id_function=operation_id,
        **options,
    )
    app.state.settings = settings
    app.state.registry = registry
    app.state.api_keys = [k.encode() for k in settings.api_key_list()]
    app.state.metrics = Metrics()
    app.state.activity = Activity()  # requests in flight: may a large batch run whole?
    app.state.segments = segments
    app.state.batches_in_flight = 0
    # Each robot's equations in explicit form, derived once in a child process (in slots of
    # their own: a costly derivation never holds a builder an upload waits for) and kept in
    # memory and on disk.
    app.state.equations = EquationsCache(
        settings.data_dir,
        settings.equations_timeout_s,
        BuildSlots(
            build_slot_count(settings.max_concurrent_derivations),
            settings.build_queue_timeout_s,
            names=DERIVATIONS,
        ),
        max_bytes=settings.equations_cache_mb * 1024 * 1024,
        memory_mb=settings.equations_memory_mb,
    )
    app.state.off_loop_slots = asyncio.Semaphore(_usable_cpus())
    app.state.answers_in_flight = AnswerBytesInFlight(settings.max_answer_bytes_in_flight)
    # Large mass-matrix and Coriolis batches shared with helper processes (started on the
    # first such batch); -1: one per CPU left to this serving process (its share of the CPUs
    # when there are several) but its own. Unset: -1 for the Unix socket's requests only.
    app.state.split_over_socket_only = settings.batch_helpers is None
    wanted = settings.batch_helpers
    if wanted is None:
        wanted = -1 if settings.unix_socket is not None else 0
    helpers = wanted if wanted >= 0 else max(0, _usable_cpus() // settings.workers - 1)
    app.state.batch_split = (
        BatchSplit(helpers, settings.batch_helper_buffer_mb * 1024 * 1024) if helpers else None
    )
    install_problem_handlers(app)
    described = dynamics_routes.openapi_routes().routes  # schema-only twins of the lean routes
    # Twins of other lean routes: identify (JSON or the binary form in, JSON out), and the
    # upload (which reads its body itself)
    twins = [*identification.openapi_routes().routes, *robots.openapi_routes().routes]
    app.openapi = lambda: problem_openapi(app, described, twins)  # type: ignore[method-assign]
    app.include_router(health.router)
    # With ROBODYN_API_KEYS_SCOPE=all every /v1 route needs a key (uploads always do); the
    # lean dynamics and stream routes check it themselves (deps.check_api_key_for_all).
    private = [Depends(require_api_key_for_all)]
    app.include_router(robots.router, dependencies=private)
    app.include_router(visuals.router, dependencies=private)
    app.include_router(model_check.router, dependencies=private)
    app.include_router(equations.router, dependencies=private)
    app.include_router(identification.router, dependencies=private)
    # The dynamics routes are the hot path: they are matched first.
    app.router.routes[0:0] = [*dynamics_routes.routes(), *stream.routes(), *identification.routes()]
    app.include_router(pages.router)
    app.add_middleware(DynamicsFastPath)  # innermost: after the body limit and observability
    app.add_middleware(HeadAsGet)  # HEAD on every GET route
    app.add_middleware(KeyBeforeBody)  # 401 before a body is read
    app.add_middleware(
        BodyLimitMiddleware,
        limit=settings.max_body_bytes,
        upload_limit=settings.max_upload_bytes,
        json_limit=settings.max_json_body_bytes,
    )
    app.add_middleware(
        ObservabilityMiddleware,
        metrics=app.state.metrics,
        catalog_ids=lambda: registry.catalog,
        activity=app.state.activity,
    )  # outermost: sees every answer
    return app


def _usable_cpus() -> int:
    """The CPUs this process may run on: how many large batches are computed at once."""
    affinity = getattr(os, "sched_getaffinity", None)
    return max(1, len(affinity(0)) if affinity is not None else os.cpu_count() or 1)


def app_from_environment() -> FastAPI:
    """Factory used by `python -m service` (also in each worker process, which is why the
    logging is configured here too)."""
    settings = Settings()
    # With --workers N, uvicorn's supervisor spawned this process: it ends with the supervisor
    # (even a SIGKILL of it), and its own children with it.
    processes.die_with_supervisor()
    configure_logging(settings.log_level)
    # `python -m service` binds OpenMP teams (OMP_PROC_BIND), and libgomp bound this thread,
    # the event loop's, when pinocchio loaded: give it every CPU back before it starts others.
    unpin_this_thread()
    # Native libraries (urdfdom) and the model builder write raw text to stderr: as JSON
    # lines too, so the log stream stays one JSON object per line (service/logs.py).
    capture_native_stderr()
    return create_app(settings)
