"""Prometheus metrics by route and robot, and the request body-size limit (pure ASGI)."""

from __future__ import annotations

import time
from typing import Any

from fastapi import HTTPException
from prometheus_client import CollectorRegistry, Counter, Histogram

from service.api.problems import problem

Scope = dict[str, Any]


class Metrics:
    """Request counts and latencies. The `robot` label is the id for catalog robots and
    `upload` for uploaded models, so label cardinality stays bounded."""

    def __init__(self) -> None:
        self.registry = CollectorRegistry()
        self.requests = Counter("robodyn_requests_total", "HTTP requests answered",
                                ["method", "route", "robot", "status"], registry=self.registry)
        self.latency = Histogram(
            "robodyn_request_duration_seconds", "Time to answer a request, in seconds",
            ["method", "route", "robot"], registry=self.registry,
            buckets=(0.0002, 0.0005, 0.001, 0.002, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5,
                     1.0, 2.5, 5.0, 10.0, 30.0))


class MetricsMiddleware:
    def __init__(self, app: Any, metrics: Metrics, catalog_ids: Any) -> None:
        self.app, self.metrics, self.catalog_ids = app, metrics, catalog_ids

    async def __call__(self, scope: Scope, receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = time.perf_counter()
        status = 500

        async def send_and_record(message: dict[str, Any]) -> None:
            nonlocal status
            if message["type"] == "http.response.start":
                status = message["status"]
            await send(message)

        try:
            await self.app(scope, receive, send_and_record)
        finally:
            route = scope.get("route")
            path = getattr(route, "path", "unmatched")
            robot_id = scope.get("path_params", {}).get("robot_id")
            robot = "" if robot_id is None else (
                robot_id if robot_id in self.catalog_ids() else "upload")
            method = scope["method"]
            self.metrics.requests.labels(method, path, robot, str(status)).inc()
            self.metrics.latency.labels(method, path, robot).observe(
                time.perf_counter() - started)


class BodyLimitMiddleware:
    """Answer 413 `payload_too_large` for a body over `limit` bytes, without buffering it:
    by its Content-Length up front, or as soon as a chunked body passes the limit.
    Uploads (POST on `upload_path`) have the smaller of `limit` and `upload_limit`."""

    def __init__(self, app: Any, limit: int, upload_limit: int | None = None,
                 upload_path: str = "/v1/robots") -> None:
        self.app, self.limit = app, limit
        self.upload_limit, self.upload_path = upload_limit, upload_path

    async def __call__(self, scope: Scope, receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit, setting = self.limit, "ROBODYN_MAX_BODY_BYTES"
        if (self.upload_limit is not None and self.upload_limit < limit
                and scope["method"] == "POST" and scope["path"].rstrip("/") == self.upload_path):
            limit, setting = self.upload_limit, "ROBODYN_MAX_UPLOAD_BYTES"
        detail = f"the request body is larger than the limit of {limit} bytes ({setting})"
        for name, value in scope.get("headers", []):
            if name == b"content-length":
                try:
                    too_big = int(value) > limit
                except ValueError:
                    too_big = False
                if too_big:
                    await problem("payload_too_large", "Payload too large", detail)(
                        scope, receive, send)
                    return
        received = 0
        started = False

        async def limited_receive() -> dict[str, Any]:
            nonlocal received
            message: dict[str, Any] = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    raise _TooLarge(detail)
            return message

        async def tracking_send(message: dict[str, Any]) -> None:
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
            await send(message)

        try:
            await self.app(scope, limited_receive, tracking_send)
        except _TooLarge:  # raised where no handler turned it into an answer
            if not started:
                await problem("payload_too_large", "Payload too large", detail)(
                    scope, receive, send)


class _TooLarge(HTTPException):
    """Raised from `receive`; an HTTPException so the framework's body reader re-raises it."""

    def __init__(self, detail: str) -> None:
        super().__init__(status_code=413, detail=detail)
