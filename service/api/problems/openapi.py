"""The OpenAPI document as generated clients need it.

FastAPI's own document is rewritten in one place, so that routes added anywhere get the same
treatment:

- **operationIds** are the route's name in camelCase (`mass-matrix` → `massMatrix`,
  `list_robots` → `listRobots`): `operation_id` is the app's `generate_unique_id_function`, and
  the schema-only twins of the dynamics routes get theirs the same way.
- **Errors** are RFC 9457 problem+json: every documented error response gets the `Problem`
  schema, every operation a `default` problem response (400 malformed body, 401 with API keys,
  413, 415, 500, 503 may answer any of them). `Problem.code` is an enum of every code of the
  code → status table (`service.api.problems.handlers.STATUS_BY_CODE`), and its extension
  members are typed.
- **Request fields with a default are optional.** They are never `required`; besides, in
  schemas used only in request bodies the `default` keyword is moved into the description and
  `examples`, because generators such as openapi-typescript (default settings) type every
  property that has a `default` as always present, which is true of answers but not of requests.
- **The binary form** (`BINARY_MEDIA_TYPE`) is a content type of every dynamics request body and
  answer, beside JSON; the progress stream (`PROGRESS_MEDIA_TYPE`) one of the answers of the
  dynamics routes and identify.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator, Sequence
from typing import Any

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi
from fastapi.routing import APIRoute
from starlette.routing import BaseRoute

from service.api.encoding.binary import BINARY_MEDIA_TYPE
from service.api.problems.handlers import STATUS_BY_CODE
from service.api.progress import PROGRESS_MEDIA_TYPE

PROBLEM_MEDIA_TYPE = "application/problem+json"
PROBLEM_REF = {"$ref": "#/components/schemas/Problem"}
_METHODS = {"get", "put", "post", "delete", "patch", "head", "options", "trace"}


def operation_id(route: APIRoute) -> str:
    """The operationId of a route: its name in camelCase (`mass-matrix` → `massMatrix`)."""
    words = [w for w in re.split(r"[-_\s]+", route.name) if w]
    return words[0].lower() + "".join(w[:1].upper() + w[1:] for w in words[1:])


def problem_schema() -> dict[str, Any]:
    """The JSON schema of a problem answer: every code of the table, typed extension members."""
    codes = sorted(STATUS_BY_CODE)
    listed = ", ".join(f"`{code}` {STATUS_BY_CODE[code]}" for code in codes)
    names = {"type": "array", "items": {"type": "string"}}
    return {
        "title": "Problem",
        "type": "object",
        "description": "RFC 9457 problem details with a stable machine-readable `code`. Besides "
        "the members below, a problem may carry others; clients should ignore "
        "members they do not know.",
        "required": ["title", "status", "detail", "code"],
        "properties": {
            "type": {"type": "string", "default": "about:blank"},
            "title": {"type": "string", "description": "A short summary of the code."},
            "status": {"type": "integer", "description": "The HTTP status of the answer."},
            "detail": {
                "type": "string",
                "description": "What is wrong, for a person: the "
                "field, the expected value, where to find valid names.",
            },
            "code": {
                "type": "string",
                "enum": codes,
                "description": f"The error code and its HTTP status: {listed}.",
            },
            "errors": {
                "type": "array",
                "description": "validation_error: one entry per "
                "mistake in the request (at most 20).",
                "items": {
                    "type": "object",
                    "required": ["loc", "msg"],
                    "properties": {
                        "loc": {
                            "type": "string",
                            "description": "Where in the body, e.g. "
                            "`q[2]` or `external_forces[0].wrench`.",
                        },
                        "msg": {"type": "string", "description": "What is wrong there."},
                    },
                },
            },
            "missing": {
                **names,
                "description": "dimension_mismatch of an input keyed by "
                "joint name: the joints it does not name.",
            },
            "unknown": {
                **names,
                "description": "dimension_mismatch of an input keyed by "
                "joint name: the names that are not joints of the robot.",
            },
            "state": {
                "type": "integer",
                "description": "In a batch: the index of the state at fault.",
            },
            "smallest_singular_value": {
                "type": "number",
                "description": "singular_configuration: σ_min of the task matrix.",
            },
            "largest_singular_value": {
                "type": "number",
                "description": "singular_configuration: σ_max of the task matrix.",
            },
            "condition_number": {
                "type": ["number", "null"],
                "description": "singular_configuration: σ_max / σ_min; null when σ_min is 0.",
            },
        },
        "additionalProperties": True,
    }


def problem_openapi(
    app: FastAPI, described: Sequence[BaseRoute] = (), twins: Sequence[BaseRoute] = ()
) -> dict[str, Any]:
    """The app's OpenAPI document, rewritten as the module docstring says (computed once).
    `described`: routes documented but served by other (lean) routes of the app; they are
    the dynamics routes, which also speak the binary form. `twins`: other lean routes'
    documentation, which declare their own media types (identify: a binary request body
    through its `openapi_extra`, a JSON answer; the upload: JSON)."""
    if app.openapi_schema:
        return app.openapi_schema
    doc = get_openapi(
        title=app.title,
        version=app.version,
        description=app.description,
        routes=[*app.routes, *described, *twins],
    )
    schemas = doc.setdefault("components", {}).setdefault("schemas", {})
    for name in ("HTTPValidationError", "ValidationError"):
        schemas.pop(name, None)
    schemas["Problem"] = problem_schema()
    paths = doc.get("paths", {})
    _name_operations(paths, [*app.routes, *described, *twins])
    for operations in paths.values():
        for operation in _operations(operations):
            _problem_responses(operation)
    _binary_content(paths, described)
    _progress_content(
        paths, [*described, *(r for r in twins if getattr(r, "name", "") == "identify")]
    )
    _optional_defaults(doc)
    app.openapi_schema = doc
    return doc


def _operations(path_item: dict[str, Any]) -> Iterator[dict[str, Any]]:
    return (op for method, op in path_item.items() if method in _METHODS)


def _name_operations(paths: dict[str, Any], routes: Sequence[BaseRoute]) -> None:
    """operationIds from the route names, also for routes FastAPI did not name itself."""
    for route in routes:
        if not isinstance(route, APIRoute) or not route.include_in_schema:
            continue
        for method in route.methods or ():
            operation = paths.get(route.path_format, {}).get(method.lower())
            if operation is not None:
                operation["operationId"] = operation_id(route)
    ids = [op["operationId"] for item in paths.values() for op in _operations(item)]
    twice = sorted({i for i in ids if ids.count(i) > 1})
    assert not twice, f"several routes have the operationId {twice}: give them distinct names"


def _problem_responses(operation: dict[str, Any]) -> None:
    problem = {PROBLEM_MEDIA_TYPE: {"schema": PROBLEM_REF}}
    responses = operation.setdefault("responses", {})
    for status, response in responses.items():
        if status.isdigit() and int(status) >= 400:
            response["content"] = problem
            if int(status) == 422 and response.get("description") == "Validation Error":
                response["description"] = "validation_error"
    responses.setdefault(
        "default", {"description": "An error (see the `code`)", "content": problem}
    )


def _binary_content(paths: dict[str, Any], described: Sequence[BaseRoute]) -> None:
    """Declare the binary form beside JSON on the dynamics routes' bodies and answers."""
    binary = {
        BINARY_MEDIA_TYPE: {
            "schema": {
                "type": "string",
                "format": "binary",
                "description": "The same members as the JSON form, arrays as float64 tensors "
                "(see docs/binary-format.md).",
            }
        }
    }
    for route in described:
        if not isinstance(route, APIRoute):
            continue
        for method in route.methods or ():
            operation = paths.get(route.path_format, {}).get(method.lower())
            if operation is None:
                continue
            body = operation.get("requestBody", {}).get("content")
            if body is not None:
                body.update(binary)
            for status, response in operation.get("responses", {}).items():
                if status.startswith("2") and "content" in response:
                    response["content"].update(binary)


def _progress_content(paths: dict[str, Any], routes: Sequence[BaseRoute]) -> None:
    """Declare the progress stream beside JSON on the answers of the dynamics routes and
    identify (asked for with `Accept: application/x-ndjson`)."""
    stream = {
        PROGRESS_MEDIA_TYPE: {
            "schema": {
                "type": "string",
                "description": 'Newline-delimited JSON: {"progress": {"done", "total", "unit", '
                '"stage"}} lines, then {"answer": <the JSON answer>} or '
                '{"problem": <a problem object>} (see docs/http-api.md, "Progress '
                'of long requests").',
            }
        }
    }
    for route in routes:
        if not isinstance(route, APIRoute):
            continue
        for method in route.methods or ():
            operation = paths.get(route.path_format, {}).get(method.lower())
            for status, response in (operation or {}).get("responses", {}).items():
                if status.startswith("2") and "content" in response:
                    response["content"].update(stream)


def _refs(node: Any) -> Iterator[str]:
    """The component schema names `node` refers to, directly or nested."""
    if isinstance(node, dict):
        ref = node.get("$ref")
        if isinstance(ref, str) and ref.startswith("#/components/schemas/"):
            yield ref.rsplit("/", 1)[1]
        for value in node.values():
            yield from _refs(value)
    elif isinstance(node, list):
        for value in node:
            yield from _refs(value)


def _reachable(roots: Iterator[str], schemas: dict[str, Any]) -> set[str]:
    seen: set[str] = set()
    todo = list(roots)
    while todo:
        name = todo.pop()
        if name in seen or name not in schemas:
            continue
        seen.add(name)
        todo.extend(_refs(schemas[name]))
    return seen


def _optional_defaults(doc: dict[str, Any]) -> None:
    """In schemas only request bodies use, a property's `default` becomes prose and an
    example (see the module docstring); it is never in `required` anyway."""
    schemas = doc["components"]["schemas"]
    operations = [op for item in doc.get("paths", {}).values() for op in _operations(item)]
    inputs = _reachable((n for op in operations for n in _refs(op.get("requestBody", {}))), schemas)
    outputs = _reachable((n for op in operations for n in _refs(op.get("responses", {}))), schemas)
    for name in inputs - outputs:
        for prop in schemas[name].get("properties", {}).values():
            if "default" not in prop:
                continue
            default = prop.pop("default")
            if default is not None:
                shown = json.dumps(default, ensure_ascii=False)
                text = prop.get("description", "").rstrip()
                prop["description"] = f"{text} Default: `{shown}`.".lstrip()
                prop.setdefault("examples", [default])
