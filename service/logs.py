"""Logging: one JSON object per line on stderr, at the level of `ROBODYN_LOG_LEVEL`.

Every record becomes `{"ts", "level", "logger", "message", ...}`; a record logged with
`extra={"fields": {...}}` (the per-request access line) carries those fields at the top level,
and a record logged while a request is being answered carries its `request_id`. Tracebacks go
in `"exc"` as one string, so a log collector never splits a record over several lines.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import threading
import time
from contextvars import ContextVar
from typing import Any

import orjson

LEVELS = ("debug", "info", "warning", "error", "critical")

# The id of the request being answered in this task (set by the observability middleware).
REQUEST_ID: ContextVar[str | None] = ContextVar("robodyn_request_id", default=None)


_second: tuple[int, str] = (0, "1970-01-01T00:00:00")  # the last second formatted, cached


def utc_timestamp(seconds: float) -> str:
    """`seconds` since the epoch as ISO 8601 UTC with milliseconds: 2025-01-31T12:00:00.123Z."""
    global _second
    whole = int(seconds)
    if _second[0] != whole:
        _second = (whole, time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(whole)))
    return f"{_second[1]}.{int((seconds - whole) * 1000):03d}Z"


class JSONFormatter(logging.Formatter):
    """Formats a record as one line of JSON (orjson), merging `record.fields` when present."""

    def format(self, record: logging.LogRecord) -> str:
        out: dict[str, Any] = {
            "ts": utc_timestamp(record.created),
            "level": record.levelname.lower(),
            "logger": record.name,
            "message": record.getMessage(),
        }
        fields = getattr(record, "fields", None)
        if fields:
            out.update(fields)
        elif (request_id := REQUEST_ID.get()) is not None:
            out["request_id"] = request_id
        if record.exc_info:
            out["exc"] = self.formatException(record.exc_info)
        elif record.exc_text:
            out["exc"] = record.exc_text
        return orjson.dumps(out, default=str).decode()


class JSONLineHandler(logging.StreamHandler):  # type: ignore[type-arg]
    """The handler `configure_logging` installs: JSON lines on a stream.

    `write_fields` is the per-request fast path: the same line `JSONFormatter` makes of a record
    logged with `extra={"fields": fields}`, without building a LogRecord (a third of the cost)."""

    def write_fields(self, level: str, logger: str, message: str, fields: dict[str, Any]) -> None:
        line = orjson.dumps(
            {
                "ts": utc_timestamp(time.time()),
                "level": level,
                "logger": logger,
                "message": message,
                **fields,
            },
            default=str,
        ).decode()
        with self.lock:  # type: ignore[union-attr]  # created by Handler.__init__
            try:
                self.stream.write(line + "\n")
                self.stream.flush()
            except (OSError, ValueError):  # a closed or broken stream loses the line, as
                pass  # Handler.handleError does by default


def sole_json_handler(logger: logging.Logger) -> JSONLineHandler | None:
    """The `JSONLineHandler` that alone receives the records of `logger`, if there is one (no
    other handler or filter on the way to the root): then writing to it directly is the same
    as logging. Under a test's log capture, for instance, this is None."""
    node: logging.Logger | None = logger
    root = logging.root
    while node is not None and node is not root:
        if node.handlers or node.filters or not node.propagate:
            return None
        node = node.parent
    if len(root.handlers) != 1 or root.filters:
        return None
    handler = root.handlers[0]
    if isinstance(handler, JSONLineHandler) and not handler.filters:
        return handler
    return None


def parse_level(name: str) -> int:
    """The logging level named `name` (case-insensitive); ValueError naming the valid ones."""
    if name.strip().lower() not in LEVELS:
        raise ValueError(f"unknown log level {name!r}; use one of {', '.join(LEVELS)}")
    return logging.getLevelName(name.strip().upper())  # type: ignore[no-any-return]


def configure_logging(level: str, stream: Any = None) -> None:
    """Send every record of the process to `stream` (stderr) as JSON lines at `level`.

    Idempotent: a second call replaces the handler of the first (the server calls it in the
    parent process and again in each worker process)."""
    numeric = parse_level(level)
    root = logging.getLogger()
    for handler in [h for h in root.handlers if isinstance(h, JSONLineHandler)]:
        root.removeHandler(handler)
    handler = JSONLineHandler(stream or sys.stderr)
    handler.setFormatter(JSONFormatter())
    root.addHandler(handler)
    root.setLevel(numeric)
    # uvicorn's own loggers propagate to the root handler; its access log is replaced by ours.
    for name in ("uvicorn", "uvicorn.error", "uvicorn.asgi"):
        logging.getLogger(name).handlers = []
        logging.getLogger(name).propagate = True
    access = logging.getLogger("uvicorn.access")
    access.handlers, access.propagate, access.disabled = [], False, True


_NATIVE_LOGGER = "robodyn.native"


def capture_native_stderr() -> None:
    """Keep the JSON log stream whole when native code writes to stderr.

    C++ libraries (urdfdom prints raw text when a model fails to parse) and child processes
    write to file descriptor 2, past Python's logging. After this call the log handler writes
    to a duplicate of the original stderr, and descriptor 2 becomes a pipe read by a thread
    that logs each line written to it as one JSON record (level warning, logger
    `robodyn.native`); a line that already is a JSON object is passed on as it is. Child
    processes started later (the model builder) inherit the pipe. Idempotent; a no-op when
    stderr is not a file descriptor."""
    global _capturing
    if _capturing:
        return
    try:
        sys.stderr.flush()
        original = os.dup(2)
    except (OSError, ValueError, AttributeError):
        return
    stream = os.fdopen(original, "w", buffering=1, encoding="utf-8", errors="replace")
    read_end, write_end = os.pipe()
    os.dup2(write_end, 2)
    os.close(write_end)
    sys.stderr = stream  # Python-level writes (and the log handler) go to the real stderr
    root = logging.getLogger()
    for handler in root.handlers:
        if isinstance(handler, JSONLineHandler):
            handler.setStream(stream)
    threading.Thread(
        target=_forward_native_lines, args=(read_end, stream), name="native-stderr", daemon=True
    ).start()
    _capturing = True


_capturing = False


def _forward_native_lines(read_end: int, stream: Any) -> None:
    log = logging.getLogger(_NATIVE_LOGGER)
    with os.fdopen(read_end, "rb") as pipe:
        for raw in pipe:
            text = raw.decode("utf-8", "replace").rstrip("\r\n")
            if not text.strip():
                continue
            if text.startswith("{"):
                try:
                    orjson.loads(text)
                except orjson.JSONDecodeError:
                    pass
                else:
                    with contextlib.suppress(OSError, ValueError):
                        stream.write(text + "\n")
                    continue
            log.warning("%s", text[:4000])
