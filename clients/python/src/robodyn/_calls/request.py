"""The one request builder of the computing routes (`request`), and `route_call` for the others.

`request(robot_id, quantity, read, options, payloads=..., optional=("v",), q=q, v=v)` is
`POST /v1/robots/{robot_id}/{quantity}`: the joint-space inputs are checked together (one state
or a batch of N), the other body members are `options`, `payloads` is added to them, the
answer is read by `read(body, batched, rows)` — usually a result type's `from_json` — and a
batch of arrays can be sent in chunks of states when progress is asked for.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any, TypeVar
from urllib.parse import quote

import numpy as np

from robodyn import outputs, progress
from robodyn.arrays import ArrayLike, answer_array, batch_rows, large_joint_states
from robodyn.core import Call
from robodyn.errors import InputError
from robodyn.payloads import PayloadsLike, payloads_body

T = TypeVar("T")
Read = Callable[[Any, bool, "int | None"], T]
"""Reads an answer: `read(decoded body, batched, rows)` (rows: states of a batch, else None)."""

ROBOT = "/v1/robots/{robot_id}"


def route_call(
    method: str,
    route: str,
    read: Callable[[int, Any], T],
    robot_id: str | None = None,
    body: Any = None,
    accept: frozenset[int] = frozenset(),
    idempotent: bool = True,
) -> Call[T]:
    """A call of `method route` (the robot id checked and quoted into the route's
    `{robot_id}`), its answer read by `read(status, body)`."""
    path = route
    if robot_id is not None:
        if not isinstance(robot_id, str):
            raise TypeError(f"robot_id must be a str, not {type(robot_id).__name__}")
        if not robot_id:
            raise InputError("robot_id is empty; robots() lists the valid ids")
        path = route.format(robot_id=quote(robot_id, safe=""))
    return Call(method, route, path, read, json=body, accept=accept, idempotent=idempotent)


def request(
    robot_id: str,
    quantity: str,
    read: Read[T],
    options: Mapping[str, Any] | None = None,
    *,
    payloads: PayloadsLike | None = None,
    optional: tuple[str, ...] = (),
    binary_form: bool = True,
    independent_rows: bool = True,
    **inputs: ArrayLike | None,
) -> Call[T]:
    """`POST /v1/robots/{robot_id}/{quantity}` with the joint-space `inputs` (those named in
    `optional` are not sent when None), the other body members `options` (checked by the
    caller) and `payloads`; the answer read by `read`. `binary_form=False` keeps the request
    JSON however large. `independent_rows=False`: the rows of 2-D inputs are one trajectory,
    path or log rather than a batch of states, and are never sent in chunks (with progress,
    the server's progress stream is asked for instead)."""
    fields = {**(options or {}), **payloads_body(payloads)}
    return _request(
        robot_id,
        quantity,
        read,
        fields,
        binary_form,
        independent_rows,
        {k: x for k, x in inputs.items() if x is not None or k not in optional},
    )


def _request(
    robot_id: str,
    quantity: str,
    read: Read[T],
    fields: Mapping[str, Any],
    binary_form: bool,
    independent_rows: bool,
    inputs: Mapping[str, Any],
) -> Call[T]:
    arrays, batched, unchecked = large_joint_states(inputs)
    rows = batch_rows(arrays, batched)
    call = route_call(
        "POST",
        f"{ROBOT}/{quantity}",
        lambda status, body: read(body, batched, rows),
        robot_id,
        body=dict(fields) or None,
    )
    # one motion, path or log: one computation, whose progress the server streams
    call = replace(
        call,
        arrays=arrays,
        unchecked=unchecked,
        binary_form=binary_form,
        progress_stream=not independent_rows,
    )
    if rows is not None and independent_rows and _splittable(arrays, fields):

        def plan() -> progress.Plan[T]:
            parts: list[T] = []
            for i in range(0, rows, progress.CHUNK_STATES):
                j = min(i + progress.CHUNK_STATES, rows)
                part = _request(
                    robot_id,
                    quantity,
                    read,
                    fields,
                    binary_form,
                    True,
                    {k: a[i:j] for k, a in arrays.items()},
                )
                parts.append((yield (part, j)))
            return outputs.join(parts)

        return replace(call, chunks=progress.Chunks(rows, "states", progress.CHUNK_STATES, plan))
    return call


def _splittable(arrays: Mapping[str, Any], fields: Mapping[str, Any]) -> bool:
    """Whether a batch can be sent in chunks of states: arrays (not name-keyed inputs) whose
    other fields do not depend on the state (per-state external wrenches do)."""
    return all(isinstance(a, np.ndarray) for a in arrays.values()) and not fields.get(
        "external_forces"
    )


def array(key: str, ndim: int) -> Read[np.ndarray]:
    """Read the answer's field `key`, `ndim` dimensions per state (a matrix is square)."""

    def read(body: Any, batched: bool, rows: int | None) -> np.ndarray:
        return answer_array(body, key, ndim, batched, rows)

    return read
