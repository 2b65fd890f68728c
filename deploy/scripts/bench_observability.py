"""What the observability middleware adds to one request, in microseconds.

    .venv/bin/python deploy/scripts/bench_observability.py [--requests 50000]

Calls a minimal ASGI app that answers like a dynamics route (it sets `scope["robodyn"]`) bare,
then wrapped in `ObservabilityMiddleware` with the access log off (level warning), then with
the access log on (level info, JSON lines written to /dev/null through the service's handler).
Prints one JSON line: microseconds per request for each, and the middleware's cost.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import os
import time
from typing import Any

from service.api.middleware.observability import Metrics, ObservabilityMiddleware
from service.logs import configure_logging


class _Route:
    path = "/v1/robots/{robot_id}/gravity"


async def _route(scope: dict[str, Any], receive: Any, send: Any) -> None:
    scope["route"], scope["path_params"] = _Route, {"robot_id": "ur5"}
    scope["robodyn"] = {
        "robot": "ur5",
        "quantity": "gravity",
        "batch_size": 1,
        "compute_seconds": 1e-5,
    }
    await send(
        {
            "type": "http.response.start",
            "status": 200,
            "headers": [(b"content-type", b"application/json")],
        }
    )
    await send({"type": "http.response.body", "body": b"{}"})


async def _receive() -> dict[str, Any]:
    return {"type": "http.request", "body": b""}


async def _send(message: Any) -> None:
    pass


async def _per_request(app: Any, n: int) -> float:
    started = time.perf_counter()
    for _ in range(n):
        scope = {
            "type": "http",
            "method": "POST",
            "headers": [(b"host", b"x"), (b"content-type", b"application/json")],
        }
        await app(scope, _receive, _send)
    return (time.perf_counter() - started) / n * 1e6


async def _main(n: int, rounds: int) -> dict[str, float]:
    """The best of `rounds` interleaved rounds of each (the machine may be shared)."""
    wrapped = ObservabilityMiddleware(_route, Metrics(), lambda: {"ur5"})
    root = logging.getLogger()
    with open(os.devnull, "w") as devnull:
        configure_logging("info", stream=devnull)
        await _per_request(wrapped, n // 10)  # warm up
        bare, log_off, log_on = [], [], []
        for _ in range(rounds):
            bare.append(await _per_request(_route, n))
            root.setLevel(logging.WARNING)
            log_off.append(await _per_request(wrapped, n))
            root.setLevel(logging.INFO)
            log_on.append(await _per_request(wrapped, n))
    bare, log_off, log_on = min(bare), min(log_off), min(log_on)  # type: ignore[assignment]
    return {
        "bare_us": round(bare, 2),
        "middleware_log_off_us": round(log_off, 2),
        "middleware_log_on_us": round(log_on, 2),
        "added_log_off_us": round(log_off - bare, 2),
        "added_log_on_us": round(log_on - bare, 2),
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--requests", type=int, default=10_000, help="per round")
    parser.add_argument("--rounds", type=int, default=15)
    args = parser.parse_args(argv)
    print(json.dumps(asyncio.run(_main(args.requests, args.rounds))))


if __name__ == "__main__":
    main()
