"""Hostile request bodies whose cost is in the validation, not the computation: arrays of
100,000s of wrong values, millions of unknown members, names of a megabyte, joints named
twice. Each is a body for a route with its expected answer, at three sizes: `small` runs
in-process (`test_floods.py`), `medium` (the reproductions' size: 100,000 strings in 400 kB)
against a real server with /health/live probed throughout (p99 < 0.25 s), and `large` (the sizes
that froze a server for minutes: 1.5 M strings, 1 M unknown members of a dynamics body, 5 M of
an upload) against a real server within a few seconds (`test_floods_server.py`, slow suite),
/health/live probed throughout for those read off the serving process (`responsive_at_large`).

Every answer must be a small 422 (< 2 kB: names shortened, errors bounded). What remains of the
work is reading the body: pydantic parses all of it (and, for a union-typed field whose value
is of none of its types, converts it to Python objects once per such member), so refusing a
body costs a few parses of it, never one error object per mistake.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import orjson

from service.api.encoding import binary

JOINTS = ("shoulder", "elbow")  # planar_arm's joints
MEGABYTE_NAME = "x" * 1_000_000


@dataclass(frozen=True)
class Flood:
    id: str
    path: str  # on planar_arm for the dynamics routes
    body: Callable[[int], bytes]  # size → body
    small: int  # the size run in-process
    medium: int  # the size run against a real server, /health/live probed (slow suite)
    large: int  # the size run against a real server, in a bounded time (slow suite)
    fragment: str  # in the answer's detail
    content_type: str = "application/json"
    # /health/live's p99 < 0.25 s at the `large` size too (the body is read off the serving
    # process: an upload's in a child process)
    responsive_at_large: bool = False


def _json(make: Callable[[int], object]) -> Callable[[int], bytes]:
    return lambda n: orjson.dumps(make(n))


def _unknown(n: int) -> dict[str, int]:
    return {f"m{i}": 1 for i in range(n)}


def _binary_metadata(n: int) -> bytes:
    """A binary body (safetensors) whose `__metadata__` has `n` unknown names."""
    q = np.zeros(2)
    head = binary.header_bytes({f"m{i}": 1 for i in range(n)}, {"q": q.shape})
    return head + q.tobytes()


def _repeated_joint(n: int) -> bytes:
    members = ", ".join(f'"{name}": 0.1' for name in JOINTS)
    return f'{{"q": {{{members}, "{JOINTS[0]}": 0.2}}}}'.encode()


GRAVITY = "/v1/robots/planar_arm/gravity"
FLOODS = [
    Flood(
        "q-of-strings",
        GRAVITY,
        _json(lambda n: {"q": ["x"] * n}),
        100_000,
        100_000,
        1_500_000,
        "must be a valid number",
    ),
    # a batch of wrong rows costs more per byte (each row is converted for the forms that
    # refuse the batch whole): 200 kB stays under the probe's bound on a loaded 2-core machine
    Flood(
        "batch-of-strings",
        GRAVITY,
        _json(lambda n: {"q": [["x", "y"]] * n}),
        20_000,
        20_000,
        500_000,
        "must be a valid number",
    ),
    Flood(
        "name-keyed-strings",
        GRAVITY,
        _json(lambda n: {"q": {f"j{i}": "x" for i in range(n)}}),
        50_000,
        50_000,
        500_000,
        "must be",
    ),
    Flood(
        "wrench-of-strings",
        "/v1/robots/planar_arm/inverse-dynamics",
        _json(
            lambda n: {
                "q": [0, 0],
                "v": [0, 0],
                "a": [0, 0],
                "external_forces": [{"frame": "elbow", "wrench": ["x"] * n}],
            }
        ),
        100_000,
        100_000,
        1_500_000,
        "must be",
    ),
    Flood(
        "unknown-members",
        GRAVITY,
        _json(lambda n: {"q": [0, 0], **_unknown(n)}),
        100_000,
        100_000,
        1_000_000,
        "is not a field of this request",
    ),
    Flood(
        "unknown-members-of-an-upload",
        "/v1/robots",
        _json(lambda n: {"urdf": "<robot name='r'/>", **_unknown(n)}),
        200_000,
        100_000,
        5_000_000,
        "members that are not fields of this request",
        responsive_at_large=True,
    ),
    Flood(
        "unknown-names-in-binary-metadata",
        GRAVITY,
        _binary_metadata,
        20_000,
        70_000,
        70_000,
        "names that are not fields of this request",
        content_type=binary.BINARY_MEDIA_TYPE,
    ),
    Flood(
        "megabyte-member-name",
        GRAVITY,
        _json(lambda n: {"q": [0, 0], MEGABYTE_NAME: 1}),
        1,
        1,
        1,
        "is not a field",
    ),
    Flood(
        "megabyte-joint-name",
        GRAVITY,
        _json(lambda n: {"q": {MEGABYTE_NAME: 1}}),
        1,
        1,
        1,
        "must have at most 256 characters",
    ),
    Flood(
        "megabyte-upload-member-name",
        "/v1/robots",
        _json(lambda n: {"urdf": "<robot name='r'/>", MEGABYTE_NAME: 1}),
        1,
        1,
        1,
        "is not a field",
    ),
    Flood("joint-named-twice", GRAVITY, _repeated_joint, 1, 1, 1, "twice"),
    Flood(
        "joint-state-naming-a-joint-twice",
        GRAVITY,
        _json(lambda n: {"q": {"name": [*JOINTS, JOINTS[0]], "position": [0.1, 0.2, 0.3]}}),
        1,
        1,
        1,
        "twice",
    ),
]
ANSWER_BYTES = 2000  # an answer to any flood is smaller than this
