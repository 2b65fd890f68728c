"""Request builders of the equation of motion M(q) a + C(q, v) v + g(q) = τ: its terms, inverse
and forward dynamics. (The clients' docstrings describe them.)"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from robodyn import request_options
from robodyn._calls.request import array, request
from robodyn.arrays import ArrayLike, answer_array
from robodyn.core import Call
from robodyn.payloads import PayloadsLike


def mass_matrix(
    robot_id: str, q: ArrayLike, *, payloads: PayloadsLike | None = None
) -> Call[np.ndarray]:
    return request(robot_id, "mass-matrix", array("mass_matrix", 2), payloads=payloads, q=q)


def gravity(
    robot_id: str, q: ArrayLike, *, payloads: PayloadsLike | None = None
) -> Call[np.ndarray]:
    return request(robot_id, "gravity", array("gravity", 1), payloads=payloads, q=q)


def _coriolis(body: Any, batched: bool, rows: int | None) -> tuple[np.ndarray, np.ndarray]:
    return (
        answer_array(body, "coriolis_matrix", 2, batched, rows),
        answer_array(body, "coriolis_forces", 1, batched, rows),
    )


def coriolis(
    robot_id: str, q: ArrayLike, v: ArrayLike, *, payloads: PayloadsLike | None = None
) -> Call[tuple[np.ndarray, np.ndarray]]:
    return request(robot_id, "coriolis", _coriolis, payloads=payloads, q=q, v=v)


def nonlinear_effects(
    robot_id: str, q: ArrayLike, v: ArrayLike, *, payloads: PayloadsLike | None = None
) -> Call[np.ndarray]:
    return request(
        robot_id, "nonlinear-effects", array("nonlinear_effects", 1), payloads=payloads, q=q, v=v
    )


def inverse_dynamics(
    robot_id: str,
    q: ArrayLike,
    v: ArrayLike,
    a: ArrayLike,
    *,
    external_forces: Sequence[Mapping[str, Any]] | None = None,
    payloads: PayloadsLike | None = None,
    friction: bool = False,
) -> Call[np.ndarray]:
    options = _inverse_dynamics_options(external_forces, friction, loads=False)
    return request(
        robot_id, "inverse-dynamics", array("tau", 1), options, payloads=payloads, q=q, v=v, a=a
    )


def _inverse_dynamics_options(
    external_forces: Sequence[Mapping[str, Any]] | None, friction: bool, *, loads: bool
) -> dict[str, Any]:
    """The options of an inverse-dynamics request: external forces, friction, joint loads."""
    options: dict[str, Any] = dict(request_options.external_forces(external_forces))
    if friction:
        options["friction"] = True
    if loads:
        options["loads"] = True
    return options


def _joint_wrenches(body: Any, batched: bool, rows: int | None) -> tuple[np.ndarray, np.ndarray]:
    return (
        answer_array(body, "tau", 1, batched, rows),
        answer_array(body, "joint_wrenches", 2, batched, rows, square=False),
    )


def joint_wrenches(
    robot_id: str,
    q: ArrayLike,
    v: ArrayLike,
    a: ArrayLike,
    *,
    external_forces: Sequence[Mapping[str, Any]] | None = None,
    payloads: PayloadsLike | None = None,
    friction: bool = False,
) -> Call[tuple[np.ndarray, np.ndarray]]:
    options = _inverse_dynamics_options(external_forces, friction, loads=True)
    return request(
        robot_id, "inverse-dynamics", _joint_wrenches, options, payloads=payloads, q=q, v=v, a=a
    )


def forward_dynamics(
    robot_id: str,
    q: ArrayLike,
    v: ArrayLike,
    tau: ArrayLike,
    *,
    external_forces: Sequence[Mapping[str, Any]] | None = None,
    payloads: PayloadsLike | None = None,
) -> Call[np.ndarray]:
    return request(
        robot_id,
        "forward-dynamics",
        array("a", 1),
        request_options.external_forces(external_forces),
        payloads=payloads,
        q=q,
        v=v,
        tau=tau,
    )
