"""Per-request observability (pure ASGI): Prometheus metrics by route and robot, one JSON
access-log line per request, `X-Request-ID` and `Server-Timing` headers. (The request body
limits are `service.api.middleware.body_limit`.)

What a route tells the middleware: a dynamics route puts
`scope["robodyn"] = {"robot": id, "quantity": its name, "batch_size": N (1 for one state),
"compute_seconds": float, "large": computed in a worker thread}` into the ASGI scope before it
answers. The middleware reads it when the response starts (for `Server-Timing:
compute;dur=<ms>`) and when the request ends (for the log line and the compute-time histogram).

Kept cheap, since a single-state answer takes tens of microseconds: metric children are cached
per label set, the log line is built only when the `robodyn.access` logger is enabled and is
written straight to the JSON handler when nothing else listens
(`deploy/scripts/bench_observability.py` measures what the middleware adds).
"""

from __future__ import annotations

import contextlib
import logging
import random
import re
import time
from collections.abc import Iterator, MutableMapping
from typing import Any

from prometheus_client import CollectorRegistry, Counter, Histogram
from prometheus_client.core import CounterMetricFamily
from prometheus_client.registry import Collector
from starlette.requests import ClientDisconnect

from service.api.activity import Activity
from service.api.cancellation import STOPPED
from service.api.problems.handlers import problem
from service.logs import REQUEST_ID, sole_json_handler
from service.server.limits import CLOSED as CONNECTIONS_CLOSED

Scope = dict[str, Any]

access_log = logging.getLogger("robodyn.access")
error_log = logging.getLogger("robodyn.api")

CLIENT_CLOSED_REQUEST = 499  # the status counted for a client that left mid-request (nginx's)

# An incoming X-Request-ID is kept when it is 1-128 characters of this set (so it cannot
# inject anything into a header or a log line); otherwise a new one is generated.
_REQUEST_ID_FORMAT = re.compile(rb"[A-Za-z0-9._~:/+=@-]{1,128}")

# Routes polled by probes and scrapers: their access lines are logged at DEBUG, not INFO.
QUIET_ROUTES = frozenset({"/health/live", "/health/ready", "/metrics"})

_LATENCY_BUCKETS = (
    0.0002,
    0.0005,
    0.001,
    0.002,
    0.005,
    0.01,
    0.025,
    0.05,
    0.1,
    0.25,
    0.5,
    1.0,
    2.5,
    5.0,
    10.0,
    30.0,
)
_COMPUTE_BUCKETS = (
    0.00001,
    0.00002,
    0.00005,
    0.0001,
    0.0002,
    0.0005,
    0.001,
    0.002,
    0.005,
    0.01,
    0.025,
    0.05,
    0.1,
    0.25,
    0.5,
    1.0,
    2.5,
    5.0,
    10.0,
    30.0,
)
_BATCH_BUCKETS = (1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000, 20000, 50000, 100000)


class Metrics:
    """Request counts, latencies, compute times and batch sizes.

    The `robot` label is the id for catalog robots, `upload` for any other robot the route
    found, `unknown` for a robot id that was not found (404), and empty on routes without a
    robot, so label cardinality stays bounded whatever ids clients send."""

    def __init__(self) -> None:
        self.registry = CollectorRegistry()
        self.requests = Counter(
            "robodyn_requests_total",
            "HTTP requests answered",
            ["method", "route", "robot", "status"],
            registry=self.registry,
        )
        self.latency = Histogram(
            "robodyn_request_duration_seconds",
            "Time from receiving a request to sending the end of its answer, in seconds",
            ["method", "route", "robot"],
            registry=self.registry,
            buckets=_LATENCY_BUCKETS,
        )
        self.compute = Histogram(
            "robodyn_compute_seconds",
            "Time spent computing the dynamics of one request (all its states), in seconds",
            ["quantity", "robot"],
            registry=self.registry,
            buckets=_COMPUTE_BUCKETS,
        )
        self.batch_size = Histogram(
            "robodyn_batch_size",
            "States per dynamics request (1 for a single state)",
            ["quantity"],
            registry=self.registry,
            buckets=_BATCH_BUCKETS,
        )
        self.registry.register(_ConnectionsClosed())
        self.registry.register(_ComputationsStopped())
        self._request_children: dict[tuple[str, str, str, int], tuple[Any, Any]] = {}
        self._compute_children: dict[tuple[str, str], tuple[Any, Any]] = {}

    def observe_request(
        self, method: str, route: str, robot: str, status: int, seconds: float
    ) -> None:
        key = (method, route, robot, status)
        children = self._request_children.get(key)
        if children is None:
            children = (
                self.requests.labels(method, route, robot, str(status)),
                self.latency.labels(method, route, robot),
            )
            self._request_children[key] = children
        children[0].inc()
        children[1].observe(seconds)

    def observe_compute(self, quantity: str, robot: str, seconds: float, states: int) -> None:
        key = (quantity, robot)
        children = self._compute_children.get(key)
        if children is None:
            children = (self.compute.labels(quantity, robot), self.batch_size.labels(quantity))
            self._compute_children[key] = children
        children[0].observe(seconds)
        children[1].observe(states)


class _ConnectionsClosed(Collector):
    """`robodyn_connections_closed_total{reason}`: connections the HTTP protocol closed
    (service/server/protocol.py): header_timeout, body_timeout, send_timeout, evicted (past
    the connection cap), refused (503 at the cap), bad_request (malformed HTTP)."""

    def collect(self) -> Iterator[CounterMetricFamily]:
        family = CounterMetricFamily(
            "robodyn_connections_closed",
            "Connections closed by the server's HTTP protocol "
            "for a timeout, the connection cap or malformed HTTP",
            labels=["reason"],
        )
        for reason, count in CONNECTIONS_CLOSED.items():
            family.add_metric([reason], count)
        yield family


class _ComputationsStopped(Collector):
    """`robodyn_computations_stopped_total{reason}`: long computations stopped before their
    end (`service.api.cancellation`): deadline (ROBODYN_REQUEST_DEADLINE_S) or disconnect."""

    def collect(self) -> Iterator[CounterMetricFamily]:
        family = CounterMetricFamily(
            "robodyn_computations_stopped",
            "Long computations stopped before their end: "
            "the request's deadline passed or its client disconnected",
            labels=["reason"],
        )
        for reason, count in STOPPED.items():
            family.add_metric([reason], count)
        yield family


def _request_id(scope: Scope) -> str:
    for name, value in scope["headers"]:
        if name == b"x-request-id":
            if _REQUEST_ID_FORMAT.fullmatch(value):
                request_id: str = value.decode("ascii")
                return request_id
            break
    return f"{random.getrandbits(128):032x}"  # an id, not a secret: no need for os.urandom


class ObservabilityMiddleware:
    """Metrics, the access log line, `X-Request-ID` and `Server-Timing` for every HTTP request."""

    def __init__(
        self, app: Any, metrics: Metrics, catalog_ids: Any, activity: Activity | None = None
    ) -> None:
        self.app, self.metrics, self.catalog_ids = app, metrics, catalog_ids
        self.activity = activity or Activity()  # (requests in flight: `service.api.activity`)

    async def __call__(self, scope: Scope, receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = time.perf_counter()
        request_id = _request_id(scope)
        REQUEST_ID.set(request_id)  # the task's own context: later log records carry it
        id_header = (b"x-request-id", request_id.encode("ascii"))
        status = 0

        async def send_with_headers(message: MutableMapping[str, Any]) -> None:
            nonlocal status
            if message["type"] == "http.response.start":
                status = message["status"]
                timing = f"app;dur={(time.perf_counter() - started) * 1e3:.3f}"
                info = scope.get("robodyn")
                if info is not None:
                    timing = f"compute;dur={info['compute_seconds'] * 1e3:.3f}, {timing}"
                message = {
                    **message,
                    "headers": [
                        *message.get("headers", ()),
                        id_header,
                        (b"server-timing", timing.encode("ascii")),
                    ],
                }
            await send(message)

        self.activity.started()
        try:
            await self.app(scope, receive, send_with_headers)
        except ClientDisconnect:
            # The client went away before its request was read in full: not a failure of
            # the service. Counted as 499 (as nginx does), logged without a traceback.
            if status == 0:
                status = CLIENT_CLOSED_REQUEST
                error_log.info(
                    "the client disconnected before sending its whole request (%s %s)",
                    scope["method"],
                    scope["path"],
                )
        except Exception:
            if status != 0:  # the answer is cut short: the server must drop the connection
                raise
            # Answered here, complete (so the connection stays usable) and with the request
            # id; logged once with its traceback, not re-raised to the server.
            error_log.exception("unexpected error on %s %s", scope["method"], scope["path"])
            answer = problem(
                "internal_error",
                "Internal error",
                "the service failed to answer this request; the failure was logged",
            )
            with contextlib.suppress(Exception):  # e.g. the client has gone
                await answer(scope, receive, send_with_headers)
            status = status or 500
        finally:
            info = scope.get("robodyn")
            self.activity.ended(info is not None and info["large"])
            self._record(scope, status or 500, time.perf_counter() - started, request_id)

    def _record(self, scope: Scope, status: int, seconds: float, request_id: str) -> None:
        route = getattr(scope.get("route"), "path", "unmatched")
        robot_id = (scope.get("path_params") or {}).get("robot_id")
        if robot_id is None:
            robot = ""
        elif robot_id in self.catalog_ids():
            robot = robot_id
        else:
            robot = "unknown" if status == 404 else "upload"
        method = scope["method"]
        self.metrics.observe_request(method, route, robot, status, seconds)
        info = scope.get("robodyn")
        if info is not None:
            self.metrics.observe_compute(
                info["quantity"], robot, info["compute_seconds"], info["batch_size"]
            )
        level = logging.DEBUG if route in QUIET_ROUTES else logging.INFO
        if not access_log.isEnabledFor(level):
            return
        fields = {
            "request_id": request_id,
            "method": method,
            "route": route,
            "robot": robot_id,
            "quantity": None,
            "batch_size": None,
            "status": status,
            "duration_ms": round(seconds * 1e3, 3),
            "compute_ms": None,
        }
        if info is not None:
            fields["quantity"], fields["batch_size"] = info["quantity"], info["batch_size"]
            fields["compute_ms"] = round(info["compute_seconds"] * 1e3, 3)
        handler = sole_json_handler(access_log)
        if handler is not None:  # the fast path, same line (service/logs.py)
            handler.write_fields(
                logging.getLevelName(level).lower(), access_log.name, "request", fields
            )
        else:
            access_log.log(level, "request", extra={"fields": fields})
