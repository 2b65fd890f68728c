"""The dynamics hot path in front of the framework's routing: `POST /v1/robots/{id}/{quantity}`
goes straight to its `Endpoint`, skipping Starlette's exception middleware, FastAPI's exit
stack and the route table (about 15 µs of a 150 µs single-state answer). It sits inside the
observability and body-limit middleware, so metrics, logs, request ids and limits are the
same; errors are answered by the app's own exception handlers, and unexpected ones propagate
to the server-error middleware exactly as from a routed endpoint. Everything else (other
methods, paths, the WebSocket stream) goes to the app.
"""

from __future__ import annotations

from typing import Any

from starlette.requests import Request
from starlette.types import Receive, Scope, Send

from service.api.dynamics import ENDPOINTS, PREFIX

_START = PREFIX + "/"


class DynamicsFastPath:
    """ASGI middleware: serve the dynamics POST routes directly."""

    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http" and scope["method"] == "POST":
            path: str = scope["path"]
            if path.startswith(_START):
                robot_id, _, quantity = path[len(_START):].partition("/")
                endpoint = ENDPOINTS.get(quantity)
                if endpoint is not None and robot_id:
                    scope["path_params"] = {"robot_id": robot_id}
                    request = Request(scope, receive)
                    try:
                        response = await endpoint.answer(request)
                    except Exception as exc:
                        handler = _handler(scope["app"].exception_handlers, exc)
                        if handler is None:
                            raise  # the server-error middleware answers 500, as for any route
                        response = await handler(request, exc)
                    await response(scope, receive, send)
                    return
        await self.app(scope, receive, send)


def _handler(handlers: dict[Any, Any], exc: Exception) -> Any:
    """The app's handler for `exc` by its class hierarchy; None for the catch-all (`Exception`,
    500), which belongs to the server-error middleware as in Starlette's own routing."""
    for cls in type(exc).__mro__:
        if cls is Exception:
            return None
        if cls in handlers:
            return handlers[cls]
    return None
