"""Make the OpenAPI document say what error answers really are: RFC 9457 problem+json.

FastAPI documents error responses as `application/json` (and 422 with its own
`HTTPValidationError` schema). robodyn answers every error with `application/problem+json` and
the `Problem` schema, and may answer any operation with a few protocol errors (400 malformed
body, 401 with API keys, 413, 415, 500, 503). This rewrites the document accordingly: every
documented error response gets the problem+json content, and every operation gets a `default`
problem response covering the others.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi
from starlette.routing import BaseRoute

PROBLEM_MEDIA_TYPE = "application/problem+json"
PROBLEM_REF = {"$ref": "#/components/schemas/Problem"}

_PROBLEM_SCHEMA = {
    "title": "Problem",
    "type": "object",
    "description": "RFC 9457 problem details with a stable machine-readable `code`.",
    "required": ["title", "status", "detail", "code"],
    "properties": {
        "type": {"type": "string", "default": "about:blank"},
        "title": {"type": "string"},
        "status": {"type": "integer"},
        "detail": {"type": "string"},
        "code": {"type": "string"},
    },
}


def problem_openapi(app: FastAPI, described: Sequence[BaseRoute] = ()) -> dict[str, Any]:
    """The app's OpenAPI document with problem+json error responses (computed once).
    `described`: routes documented but served by other (lean) routes of the app."""
    if app.openapi_schema:
        return app.openapi_schema
    doc = get_openapi(title=app.title, version=app.version, description=app.description,
                      routes=[*app.routes, *described])
    schemas = doc.setdefault("components", {}).setdefault("schemas", {})
    schemas.setdefault("Problem", _PROBLEM_SCHEMA)
    for name in ("HTTPValidationError", "ValidationError"):
        schemas.pop(name, None)
    problem = {PROBLEM_MEDIA_TYPE: {"schema": PROBLEM_REF}}
    for operations in doc.get("paths", {}).values():
        for operation in operations.values():
            responses = operation.setdefault("responses", {})
            for status, response in responses.items():
                if status.isdigit() and int(status) >= 400:
                    response["content"] = problem
                    if int(status) == 422 and response.get("description") == "Validation Error":
                        response["description"] = "validation_error"
            responses.setdefault("default", {"description": "An error (see the `code`)",
                                             "content": problem})
    app.openapi_schema = doc
    return doc
