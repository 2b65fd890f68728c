"""Whether the app has a route for a method and path: its own route table decides."""

from __future__ import annotations

from typing import Any

from starlette.routing import Match


def serves(app: Any, method: str, path: str) -> bool:
    """True when some route of `app` fully matches `method` `path` (as the router would)."""
    scope = {
        "type": "http",
        "method": method,
        "path": path,
        "root_path": "",
        "headers": [],
        "query_string": b"",
    }
    return any(route.matches(scope)[0] == Match.FULL for route in app.router.routes)
