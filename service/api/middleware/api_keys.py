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

from service.api.deps import check_api_key, check_api_key_for_all
from service.api.problems.handlers import error_response
from service.errors import Unauthorized

Scope = dict[str, Any]
# The routes that need a key whenever keys are set (`require_api_key` in the routers).
_ALWAYS_GUARDED = (("POST", re.compile(r"^/v1/robots/?$")),
                   ("POST", re.compile(r"^/v1/robots/[^/]+/reduce/?$")),
                   ("DELETE", re.compile(r"^/v1/robots/[^/]+/?$")))


class KeyBeforeBody:
    """Answer 401 `unauthorized` before reading the body of a request that needs a key and
    has none (or a wrong one)."""

    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Any, send: Any) -> None:
        if (scope["type"] == "http" and scope["path"].startswith("/v1/")
                and scope["app"].state.api_keys):
            connection = HTTPConnection(scope)
            try:
                check_api_key_for_all(connection)
                if any(scope["method"] == method and pattern.match(scope["path"])
                       for method, pattern in _ALWAYS_GUARDED):
                    check_api_key(connection)
            except Unauthorized as exc:
                await error_response(exc)(scope, receive, send)
                return
        await self.app(scope, receive, send)
