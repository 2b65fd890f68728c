"""Request builders, by topic: each public function of a topic module builds the `Call` of the
client method of the same name (with the same arguments), checking its arguments locally.

`Client`, `AsyncClient` and the streams send these calls; nothing here does I/O. A topic's
helpers have names starting with `_`, so that the public functions are exactly the builders.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from types import ModuleType
from typing import Any

from robodyn._calls import (
    centroidal,
    contacts,
    derivatives,
    equation_of_motion,
    equations,
    frames,
    health,
    identification,
    lagrangian,
    model_check,
    operational_space,
    payload_capacity,
    robots,
    simulation,
    trajectories,
)
from robodyn.core import Call


def _builders(*modules: ModuleType) -> dict[str, Callable[..., Call[Any]]]:
    return {
        name: fn
        for module in modules
        for name, fn in vars(module).items()
        if inspect.isfunction(fn) and fn.__module__ == module.__name__ and not name.startswith("_")
    }


BUILDERS = _builders(
    robots,
    model_check,
    health,
    equations,
    equation_of_motion,
    lagrangian,
    frames,
    operational_space,
    derivatives,
    centroidal,
    simulation,
    contacts,
    payload_capacity,
    trajectories,
    identification,
)
"""Client method name → its request builder."""
STREAMED = tuple(
    _builders(
        equation_of_motion,
        lagrangian,
        frames,
        operational_space,
        derivatives,
        centroidal,
        simulation,
        contacts,
        payload_capacity,
        trajectories,
    )
)
"""The methods a stream offers: the quantities of one robot (`POST /v1/robots/{id}/<quantity>`
routes the server's WebSocket also answers)."""

__all__ = [
    "BUILDERS",
    "STREAMED",
    "centroidal",
    "contacts",
    "derivatives",
    "equation_of_motion",
    "equations",
    "frames",
    "health",
    "identification",
    "lagrangian",
    "operational_space",
    "payload_capacity",
    "robots",
    "simulation",
    "trajectories",
]
