"""HEAD on every GET route (pure ASGI): FastAPI's routes answer only the methods they declare,
so HEAD was a 405. A HEAD request is served as the GET it stands for, with the same status and
headers (Content-Length included) and no body (RFC 9110 §9.3.2)."""

from __future__ import annotations

from typing import Any

Scope = dict[str, Any]


class HeadAsGet:
    """Serve HEAD as GET without the body; everything else passes through untouched."""

    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Any, send: Any) -> None:
        if scope["type"] != "http" or scope["method"] != "HEAD":
            await self.app(scope, receive, send)
            return

        async def without_body(message: dict[str, Any]) -> None:
            if message["type"] == "http.response.body":
                if message.get("more_body", False):
                    return  # only the last (empty) piece is sent
                message = {"type": "http.response.body", "body": b""}
            await send(message)

        scope["method"] = "GET"  # in place: the router's `route` stays visible outside
        try:
            await self.app(scope, receive, without_body)
        finally:
            scope["method"] = "HEAD"  # for the access log and the metrics
