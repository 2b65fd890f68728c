"""Large JSON bodies of the dynamics routes and of identify, parsed in a helper process.

Parsing and validating JSON (pydantic's `model_validate_json`) is one C call that holds the GIL
for its whole duration: about 0.14 s for the 15 MB body of a 100,000-sample trajectory check,
during which the event loop (and /health/live) waits, whichever thread runs it. A body of more
than `ISOLATED_JSON_BYTES` is therefore parsed by the very same validation (a dynamics route's
`Endpoint.parse_json`, identify's model) in a long-lived helper process (`HELPERS`, a
`service.processes.HelperPool` of `JSON_WORKERS` spawned processes at a lower CPU priority,
started by the first such body, which waits about two seconds more for its imports; spawned,
not forked from the builders' forkserver: it is not a builder, whose count and CPU are bounded
on their own); the serving process only sends the bytes and gets back the arrays as float64
arrays (a copy of memory, no Python floats to build) and the options. Validation and domain
errors come back as the same errors. A helper that dies (e.g. killed for memory), or that does
not answer within `HELPER_TIMEOUT_S` (stopped, hung: it is killed), is replaced; that body is
parsed in process instead (at most `ROBODYN_MAX_JSON_BODY_BYTES`: about a second of the event
loop at worst), so the answer never depends on the helper and never waits for it longer.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from concurrent.futures.process import BrokenProcessPool
from typing import Any, TypeVar

import numpy as np
import orjson
from fastapi.exceptions import RequestValidationError

from service import errors
from service.processes import CHILD_NICENESS, HelperPool, HelperTimedOut, ResourceLimits

log = logging.getLogger("robodyn.api")

T = TypeVar("T")
ISOLATED_JSON_BYTES = 2 * 1024 * 1024
"""JSON bodies larger than this are parsed in the helper process (~20 ms and more inline)."""
JSON_WORKERS = 1
HELPER_TIMEOUT_S = 10.0
"""How long a body waits for the helper's answer (a 16 MiB body takes it about 0.2 s); a first
body waits `HELPER_START_S` more, while the helper starts and imports its modules."""
HELPER_START_S = 30.0
HELPERS = HelperPool(
    JSON_WORKERS,
    ResourceLimits(niceness=CHILD_NICENESS),
    timeout_s=HELPER_TIMEOUT_S,
    start_timeout_s=HELPER_START_S,
)
"""The helper processes (like the builders, at a lower CPU priority: the serving process keeps
its share of the CPU)."""


def parse_isolated(parse: Callable[..., T], *args: Any) -> T:
    """`parse(*args)` — a module-level function parsing a JSON body — in the helper process;
    blocking (call it off the event loop). Raises what `parse` raises (validation errors and
    domain errors); a helper that died or did not answer in time is replaced and `parse` runs
    in this process instead."""
    try:
        kind, value = HELPERS.call(_call, parse, *args)
    except (BrokenProcessPool, HelperTimedOut) as exc:  # replaced for the next body
        why = str(exc) or type(exc).__name__
        log.warning("JSON helper gave no answer (%s): the body is parsed in process", why)
        return parse(*args)
    if kind == "ok":
        result: T = value
        return result
    if kind == "invalid":
        raise RequestValidationError(value)
    name, detail, extra = value
    raise getattr(errors, name, errors.InvalidInput)(detail, **extra)


def _call(parse: Callable[..., Any], *args: Any) -> tuple[str, Any]:
    """In the helper: ("ok", what `parse` returns), ("invalid", error objects) or ("error",
    (class name, detail, extra)); everything picklable."""
    try:
        return "ok", parse(*args)
    except RequestValidationError as exc:
        return "invalid", orjson.loads(orjson.dumps(list(exc.errors()), default=str))
    except errors.RobodynError as exc:
        return "error", (
            type(exc).__name__,
            exc.detail,
            orjson.loads(orjson.dumps(exc.extra, default=str)),
        )


def compact(value: Any) -> Any:
    """A list of numbers (or of equal rows of numbers) as a float64 array; anything else
    (inputs keyed by joint name) as it is."""
    if isinstance(value, list) and value:
        try:
            array = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            return value
        return array if array.ndim in (1, 2) else value
    return value
