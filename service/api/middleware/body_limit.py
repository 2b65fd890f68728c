"""The request body limits (pure ASGI): a body over its limit is answered 413
`payload_too_large` (problem+json) without being buffered."""

from __future__ import annotations

from typing import Any

from fastapi import HTTPException

from service.api.encoding.binary import BINARY_MEDIA_TYPE
from service.api.problems.handlers import problem

Scope = dict[str, Any]
_BINARY = BINARY_MEDIA_TYPE.encode()


class BodyLimitMiddleware:
    """Answer 413 `payload_too_large` for a body over `limit` bytes, without buffering it:
    by its Content-Length up front, or as soon as a chunked body passes the limit.
    Uploads (POST on `upload_path`) have the smaller of `limit` and `upload_limit`; any other
    body that is not in the binary form (JSON) the smaller of `limit` and `json_limit`: parsing
    JSON numbers holds the interpreter (about 0.35 s for 64 MiB, plus their conversion to
    arrays), so a JSON batch is kept to a size the event loop can afford, and larger batches
    travel in the binary form, which is read without parsing."""

    def __init__(
        self,
        app: Any,
        limit: int,
        upload_limit: int | None = None,
        upload_path: str = "/v1/robots",
        json_limit: int | None = None,
    ) -> None:
        self.app, self.limit = app, limit
        self.upload_limit, self.upload_path = upload_limit, upload_path
        self.json_limit = json_limit

    def _limit(self, scope: Scope) -> tuple[int, str]:
        """The body limit of this request and the setting that sets it."""
        limit, setting = self.limit, "ROBODYN_MAX_BODY_BYTES"
        if scope["method"] == "POST" and scope["path"].rstrip("/") == self.upload_path:
            if self.upload_limit is not None and self.upload_limit <= limit:
                return self.upload_limit, "ROBODYN_MAX_UPLOAD_BYTES"
            return limit, setting
        if self.json_limit is not None and self.json_limit < limit:
            for name, value in scope.get("headers", []):
                if name == b"content-type" and value.lower().startswith(_BINARY):
                    return limit, setting
            return self.json_limit, "ROBODYN_MAX_JSON_BODY_BYTES"
        return limit, setting

    async def __call__(self, scope: Scope, receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit, setting = self._limit(scope)
        detail = f"the request body is larger than the limit of {limit} bytes ({setting})"
        if setting == "ROBODYN_MAX_JSON_BODY_BYTES":
            detail += (
                f"; send a large batch in the binary form (Content-Type: "
                f"{BINARY_MEDIA_TYPE}, a safetensors file, up to {self.limit} bytes, "
                "ROBODYN_MAX_BODY_BYTES), or split it"
            )
        for name, value in scope.get("headers", []):
            if name == b"content-length":
                try:
                    too_big = int(value) > limit
                except ValueError:
                    too_big = False
                if too_big:
                    await problem("payload_too_large", "Payload too large", detail)(
                        scope, receive, send
                    )
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
                    scope, receive, send
                )


class _TooLarge(HTTPException):
    """Raised from `receive`; an HTTPException so the framework's body reader re-raises it."""

    def __init__(self, detail: str) -> None:
        super().__init__(status_code=413, detail=detail)
