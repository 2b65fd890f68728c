"""Request builders of identification: the inertial parameters, the regressor and identify.
(The clients' docstrings describe them.) identify's log — t, q, tau and optional v, a — goes
in the binary form when it holds `core.BINARY_FROM` numbers or more (t a tensor like the
others; the options in the metadata), else as JSON; its answer is JSON either way."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, Literal

import numpy as np

from robodyn._calls.request import ROBOT, request, route_call
from robodyn.arrays import ArrayLike, answer_array
from robodyn.core import Call
from robodyn.errors import InputError
from robodyn.identification import Identification, InertialParameters
from robodyn.request_options import choice, frame_name

Friction = Literal["none", "viscous", "coulomb-viscous"]
Method = Literal["least-squares", "physically-consistent"]
FRICTIONS: tuple[str, ...] = ("none", "viscous", "coulomb-viscous")
METHODS: tuple[str, ...] = ("least-squares", "physically-consistent")


def inertial_parameters(robot_id: str) -> Call[InertialParameters]:
    return route_call(
        "GET",
        f"{ROBOT}/inertial-parameters",
        lambda status, body: InertialParameters.from_json(body),
        robot_id,
    )


def _regressor(body: Any, batched: bool, rows: int | None) -> np.ndarray:
    return answer_array(body, "regressor", 2, batched, rows, square=False)


def regressor(robot_id: str, q: ArrayLike, v: ArrayLike, a: ArrayLike) -> Call[np.ndarray]:
    return request(robot_id, "regressor", _regressor, q=q, v=v, a=a)


def _times(t: Any) -> np.ndarray:
    try:
        arr = np.asarray(t, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError("t must be a 1-D array of sample times (s)") from None
    if arr.ndim != 1 or not np.isfinite(arr).all():
        raise InputError("t must be a 1-D array of finite sample times (s)")
    return arr


def _positive(name: str, value: Any) -> float:
    number = float(value)
    if not (math.isfinite(number) and number > 0):
        raise InputError(f"{name} must be a finite number > 0")
    return number


def _read(body: Any, batched: bool, rows: int | None) -> Identification:
    return Identification.from_json(body)


def identify(
    robot_id: str,
    t: ArrayLike,
    q: ArrayLike,
    tau: ArrayLike,
    *,
    v: ArrayLike | None = None,
    a: ArrayLike | None = None,
    friction: Friction = "coulomb-viscous",
    method: Method = "physically-consistent",
    weighted: bool = True,
    validation_fraction: float = 0.2,
    filter_hz: float | None = None,
    store: bool = True,
    payload_frame: str | None = None,
    include_series: bool = False,
) -> Call[Identification]:
    times = _times(t)
    options: dict[str, Any] = {
        "friction": choice("friction", friction, FRICTIONS),
        "method": choice("method", method, METHODS),
        "weighted": bool(weighted),
        "validation_fraction": _positive("validation_fraction", validation_fraction),
        "store": bool(store),
        "include_series": bool(include_series),
    }
    if filter_hz is not None:
        options["filter_hz"] = _positive("filter_hz", filter_hz)
    if payload_frame is not None:
        options["payload"] = {"frame": frame_name(payload_frame)}
    q_rows, tau_rows = np.asarray(q, dtype=object), np.asarray(tau, dtype=object)
    if q_rows.ndim != 2 or tau_rows.ndim != 2:
        raise InputError("q and tau must be 2-D: one row per sample (N × nq, N × nv)")
    call = request(
        robot_id,
        "identify",
        _read,
        options,
        optional=("v", "a"),
        independent_rows=False,
        q=q,
        tau=tau,
        v=v,
        a=a,
    )
    # t is one of the log's arrays, not a state's: added after the joint-space inputs are
    # checked together (a list in JSON, a tensor in the binary form)
    # (the identify route reads its body itself: never through shared memory)
    return replace(call, arrays={"t": times, **(call.arrays or {})}, shared_memory=False)
