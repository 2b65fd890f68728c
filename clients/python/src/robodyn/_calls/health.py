"""Request builders of the service's health: liveness and readiness. (The clients' docstrings
describe them.)"""

from __future__ import annotations

from typing import Any

from robodyn._calls.request import route_call
from robodyn.core import Call


def health() -> Call[dict[str, Any]]:
    return route_call("GET", "/health/live", lambda status, body: dict(body))


def ready() -> Call[bool]:
    return route_call(
        "GET", "/health/ready", lambda status, body: status != 503, accept=frozenset({503})
    )
