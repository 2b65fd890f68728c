"""RFC 9457 problem+json answers, and the one table from error `code` to HTTP status."""

from __future__ import annotations

import logging
from typing import Any

import orjson
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.requests import ClientDisconnect
from starlette.responses import Response

from service.api.encoding.binary import BINARY_MEDIA_TYPE
from service.api.problems.validation_errors import MAX_ERRORS_READ, TOO_MANY, user_errors
from service.errors import ALL_ERRORS, RobodynError, did_you_mean, problem_document

log = logging.getLogger("robodyn.api")

STATUS_BY_CODE: dict[str, int] = {
    "robot_not_found": 404,
    "asset_not_found": 404,
    "catalog_robot": 409,
    "validation_error": 422,
    "dimension_mismatch": 422,
    "invalid_configuration": 422,
    "invalid_model": 422,
    "unknown_frame": 422,
    "singular_configuration": 422,
    "non_finite_result": 422,
    "unsupported_model": 422,  # the route needs what the model lacks (a fixed base, …)
    "infeasible_path": 422,
    "payload_too_large": 413,
    "unauthorized": 401,
    "not_ready": 503,
    "overloaded": 503,
    "deadline_exceeded": 504,
    "internal_error": 500,
    # Protocol-level problems raised by the framework itself:
    "bad_request": 400,
    "not_found": 404,
    "method_not_allowed": 405,
    "unsupported_media_type": 415,  # a body that is not labelled as JSON
}
assert all(e.code in STATUS_BY_CODE for e in ALL_ERRORS)

_HTTP_CODES = {
    400: ("bad_request", "Bad request"),
    404: ("not_found", "Not found"),
    405: ("method_not_allowed", "Method not allowed"),
    415: ("unsupported_media_type", "Unsupported media type"),
    413: ("payload_too_large", "Payload too large"),
}


def problem(
    code: str,
    title: str,
    detail: str,
    headers: dict[str, str] | None = None,
    status: int | None = None,
    **extra: Any,
) -> Response:
    """A problem+json response with the status of `code` (or an explicit `status`)."""
    status = status or STATUS_BY_CODE[code]
    body = problem_document(code, title, status, detail, **extra)
    return Response(
        orjson.dumps(body),
        status_code=status,
        headers=headers,
        media_type="application/problem+json",
    )


def error_response(exc: RobodynError) -> Response:
    headers = {}
    if exc.code in ("not_ready", "overloaded"):
        headers["Retry-After"] = "1"
    if exc.code == "unauthorized":
        headers["WWW-Authenticate"] = 'Bearer realm="robodyn"'
    return problem(exc.code, exc.title, exc.detail, headers or None, **exc.extra)


async def _on_domain_error(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, RobodynError)
    return error_response(exc)


async def _on_validation_error(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, RequestValidationError)
    content_type = request.headers.get("content-type", "")
    media_type = content_type.split(";")[0].strip()
    if media_type and "json" not in media_type and media_type != BINARY_MEDIA_TYPE:
        return problem(
            "unsupported_media_type",
            "Unsupported media type",
            "send the body as JSON with 'Content-Type: application/json' "
            "(with curl: --json '{...}')",
        )
    return problem(
        "validation_error", "Invalid request", **validation_details(exc, *_body_schema(request))
    )


def _body_schema(request: Request) -> tuple[dict[str, Any] | None, dict[str, Any]]:
    """The JSON schema of the request's body in the app's OpenAPI document (None when it has
    none), and the document's component schemas; used to suggest close member names."""
    path = getattr(request.scope.get("route"), "path", None)
    try:
        doc = request.app.openapi()
        operation = doc["paths"][path][request.method.lower()]
        schema = operation["requestBody"]["content"]["application/json"]["schema"]
    except (KeyError, TypeError):
        return None, {}
    return schema, doc.get("components", {}).get("schemas", {})


def validation_details(
    exc: RequestValidationError,
    schema: dict[str, Any] | None = None,
    schemas: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """`detail` (the first mistake, located) and `errors` (up to 20, one per mistake) of a
    validation failure (`service.api.problems.validation_errors`; `schema`: the body's JSON
    schema)."""
    raw = list(exc.errors()[: MAX_ERRORS_READ + 1])  # bounded by `pydantic_errors` upstream
    count = next((e["ctx"]["count"] for e in raw if e.get("type") == TOO_MANY), None)
    errors = user_errors([e for e in raw if e.get("type") != TOO_MANY], schema, schemas)
    first = errors[0] if errors else {"loc": "body", "msg": "invalid request"}
    detail = f"{first['loc']}: {first['msg']}"
    more = (count if count is not None else len(errors)) - 1
    if more > 0:
        detail += f" (and {more} more)"
    shown = errors[:20]
    if count is not None:
        shown.append({"loc": "body", "msg": f"has {count} mistakes in all (the first are listed)"})
    return {"detail": detail, "errors": shown}


def problem_body(code: str, title: str, detail: str, **extra: Any) -> dict[str, Any]:
    """The problem+json object of `code` (for channels other than an HTTP answer)."""
    return problem_document(code, title, STATUS_BY_CODE[code], detail, **extra)


_BODY_PARSE_FAILURE = "There was an error parsing the body"  # FastAPI's 400 for a JSON body
_UNPARSABLE = {
    RecursionError: "the JSON body is nested too deeply to be read",
    UnicodeDecodeError: "the JSON body is not UTF-8 text",
}


async def _on_http_error(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, StarletteHTTPException)
    if isinstance(exc.__cause__, ClientDisconnect):  # the client left: nobody to answer
        raise exc.__cause__  # counted as 499 by the observability middleware
    if exc.status_code == 400 and exc.detail == _BODY_PARSE_FAILURE:
        # A body FastAPI could not read as JSON (too deeply nested, not UTF-8, ...) is a
        # request the schema refuses, like any other malformed JSON: 422, not 400.
        reason = next(
            (text for kind, text in _UNPARSABLE.items() if isinstance(exc.__cause__, kind)),
            "the body is not valid JSON",
        )
        return problem("validation_error", "Invalid request", f"body: {reason}")
    fallback = (
        ("bad_request", "Bad request")
        if exc.status_code < 500
        else ("internal_error", "Internal error")
    )
    code, title = _HTTP_CODES.get(exc.status_code, fallback)
    if code == "not_found":
        detail = f"no such route{_close_routes(request)}; see /openapi.json or /docs for the API"
    elif code == "method_not_allowed":
        detail = f"method {request.method} is not allowed on this route"
    elif code == "payload_too_large":  # raised by BodyLimitMiddleware, which names the limit
        detail = str(exc.detail)
    else:
        detail = str(exc.detail) if isinstance(exc.detail, str) else title
    headers = dict(exc.headers) if exc.headers else None
    return problem(code, title, detail, headers)


_LONGEST_PATH_SUGGESTED = 200  # characters; a longer path gets no suggestion


def _close_routes(request: Request) -> str:
    """ " (did you mean '/v1/robots/ur5/mass-matrix'?)" for a path close to a route of the API:
    each path template of the OpenAPI document with its parameters filled by the path's own
    segments (a template of as many segments), compared by `did_you_mean`."""
    path = request.url.path
    if len(path) > _LONGEST_PATH_SUGGESTED:
        return ""
    segments = path.strip("/").split("/")
    filled = []
    for template in request.app.openapi().get("paths", {}):
        parts = template.strip("/").split("/")
        if len(parts) == len(segments):
            pairs = zip(parts, segments, strict=True)
            filled.append("/" + "/".join(s if p.startswith("{") else p for p, s in pairs))
    return did_you_mean(path, filled, most=2, longest=_LONGEST_PATH_SUGGESTED)


async def _on_unexpected(request: Request, exc: Exception) -> Response:
    log.exception("unexpected error on %s %s", request.method, request.url.path)
    return problem(
        "internal_error",
        "Internal error",
        "the service failed to answer this request; the failure was logged",
    )


def handler_for(app: Any, exc: Exception) -> Any:
    """The app's handler for `exc` by its class hierarchy; None for the catch-all (`Exception`,
    500), which belongs to the server-error middleware as in Starlette's own routing."""
    handlers = app.exception_handlers
    for cls in type(exc).__mro__:
        if cls is Exception:
            return None
        if cls in handlers:
            return handlers[cls]
    return None


def install_problem_handlers(app: FastAPI) -> None:
    app.add_exception_handler(RobodynError, _on_domain_error)
    app.add_exception_handler(RequestValidationError, _on_validation_error)
    app.add_exception_handler(StarletteHTTPException, _on_http_error)
    app.add_exception_handler(Exception, _on_unexpected)
