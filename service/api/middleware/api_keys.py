"""API keys checked before the body is read (pure ASGI). FastAPI reads and parses a route's
body before its dependencies run, and the dynamics routes read it before their own check, so a
request without a key had its body parsed (seconds for a large one, on the event loop) just to
be answered 401. Here the key is checked on the request line and headers alone, where one is
needed whatever the body: every /v1 request with `ROBODYN_API_KEYS_SCOPE=all`, and uploads,
reductions and deletions whenever keys are set. The routes' own checks stay (the rules are
`service.api.deps`)."""

from __future__ import annotations

import re
from typing import Any

from starlette.requests import HTTPConnection

from service.api.deps import check_api_key, check_api_key_for_all, require_api_key
from service.api.problems.handlers import error_response
from service.errors import Unauthorized

Scope = dict[str, Any]


def _guarded_routes(app: Any) -> list[tuple[set[str], re.Pattern[str]]]:
    """(methods, path pattern) of the app's routes that depend on `require_api_key` (uploads,
    reductions, variants, deletions): read from the routers, so a new guarded route is
    guarded here too."""
    out = []
    routes = list(getattr(app, "routes", ()))
    while routes:
        route = routes.pop()
        included = getattr(route, "original_router", None)  # FastAPI's included routers
        if included is not None:
            routes.extend(included.routes)
            continue
        dependant = getattr(route, "dependant", None)
        todo = list(getattr(dependant, "dependencies", ()))
        while todo:
            dependency = todo.pop()
            if dependency.call is require_api_key:
                out.append((set(route.methods), route.path_regex))
                break
            todo.extend(dependency.dependencies)
    return out


class KeyBeforeBody:
    """Answer 401 `unauthorized` before reading the body of a request that needs a key and
    has none (or a wrong one)."""

    def __init__(self, app: Any) -> None:
        self.app = app
        self.guarded: list[tuple[set[str], re.Pattern[str]]] | None = None

    async def __call__(self, scope: Scope, receive: Any, send: Any) -> None:
        if (
            scope["type"] == "http"
            and scope["path"].startswith("/v1/")
            and scope["app"].state.api_keys
        ):
            if self.guarded is None:
                self.guarded = _guarded_routes(scope["app"])
            connection = HTTPConnection(scope)
            try:
                check_api_key_for_all(connection)
                if any(
                    scope["method"] in methods and pattern.match(scope["path"])
                    for methods, pattern in self.guarded
                ):
                    check_api_key(connection)
            except Unauthorized as exc:
                await error_response(exc)(scope, receive, send)
                return
        await self.app(scope, receive, send)
