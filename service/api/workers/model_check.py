"""The model check and its repairs in a child process, answers kept per robot.

The check reads mesh files, and an upload's are untrusted input: they are parsed (trimesh,
`service.registry.meshes`) only in a short-lived child forked from the builders' forkserver,
limited like a model build (address space, CPU time, the build timeout; one build slot of the
registry each, so checks and uploads share the builders' bound). A robot's answer never
changes under its id (ids are content-derived; catalog robots are the installed files), so it
is computed once per process and kept (`MAX_KEPT` robots, least recently asked dropped first).

Outcomes: the answer; `InvalidInput` (422) for a repair the robot cannot have (an unknown link,
a link without geometry repaired from it); `Overloaded` (503) when the child is starved of
CPU, killed from outside or could not start; `UnsupportedModel` (422) when the check itself
went past its limits on this model.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Sequence
from typing import Any

from service.errors import InvalidInput, Overloaded, UnsupportedModel
from service.processes import (
    ChildDied,
    ChildNotStarted,
    ChildTimedOut,
    ResourceLimits,
    killed_detail,
    run_child,
    starved,
)
from service.registry.build_process import FORKSERVER_PRELOAD
from service.registry.check_inputs import CheckInputs
from service.registry.registry import Registry

MAX_KEPT = 256
OPEN_FILES = 64

_kept: OrderedDict[str, dict[str, Any]] = OrderedDict()
_kept_lock = threading.Lock()


def _child(conn: Any, job: str, inputs: CheckInputs, selection: Any, how: str) -> None:
    """The child (its limits already set): ("ok", answer), ("invalid", detail) or
    ("failed", what)."""
    from service.dynamics.model_check import model_check, planned_repairs

    try:
        if job == "check":
            conn.send(("ok", model_check(inputs)))
        else:
            conn.send(("ok", planned_repairs(inputs, selection, how)))
    except InvalidInput as exc:
        conn.send(("invalid", exc.detail))
    except MemoryError:
        conn.send(("failed", "the model check needed more than its memory limit"))
    except Exception as exc:  # geometry it cannot use (a degenerate mesh, say): named, no trace
        conn.send(
            (
                "failed",
                f"the model check could not use this model's geometry ({type(exc).__name__})",
            )
        )
    finally:
        conn.close()


def _isolated(
    registry: Registry, job: str, inputs: CheckInputs, selection: Any = None, how: str = ""
) -> Any:
    timeout_s = registry.build_timeout_s
    memory_mb = int(registry.build_limits.get("memory_mb", 1024))
    cpu_s = int(registry.build_limits.get("cpu_s", 20))
    try:
        with registry.build_slots.slot():
            answer = run_child(
                _child,
                (job, inputs, selection, how),
                timeout_s=timeout_s,
                limits=ResourceLimits(memory_mb=memory_mb, cpu_s=cpu_s, open_files=OPEN_FILES),
                preload=FORKSERVER_PRELOAD,
            )
    except ChildNotStarted:
        raise Overloaded("could not start a model check process; retry shortly") from None
    except ChildTimedOut as exc:
        if starved(exc.cpu_s, timeout_s):
            raise Overloaded("the model check got too little CPU time; retry shortly") from None
        raise UnsupportedModel(
            f"checking this model took longer than {timeout_s:g} s (ROBODYN_BUILD_TIMEOUT_S)"
        ) from None
    except ChildDied as exc:
        if exc.killed_from_outside(cpu_s):
            raise Overloaded(killed_detail("the model check", exc.exitcode)) from None
        raise UnsupportedModel(
            f"checking this model went past its limits ({memory_mb} MB, {cpu_s} s of CPU: "
            "ROBODYN_BUILD_MEMORY_MB, ROBODYN_BUILD_CPU_S)"
        ) from None
    if answer[0] == "invalid":
        raise InvalidInput(answer[1])
    if answer[0] == "failed":
        raise UnsupportedModel(answer[1])
    return answer[1]


def model_check_answer(registry: Registry, robot_id: str) -> dict[str, Any]:
    """`GET /v1/robots/{id}/model-check`'s answer. Blocking: call it off the event loop."""
    robot = registry.get(robot_id)
    with _kept_lock:
        if robot.id in _kept:
            _kept.move_to_end(robot.id)
            return _kept[robot.id]
    answer: dict[str, Any] = _isolated(registry, "check", registry.check_inputs(robot.id))
    with _kept_lock:
        _kept[robot.id] = answer
        while len(_kept) > MAX_KEPT:
            _kept.popitem(last=False)
    return answer


def variant_repairs(
    registry: Registry, robot_id: str, selection: str | Sequence[str], how: str
) -> list[dict[str, Any]]:
    """The repairs of `inertias: {"links": selection, "from": how}` on robot `robot_id`."""
    repairs: list[dict[str, Any]] = _isolated(
        registry, "repairs", registry.check_inputs(robot_id), selection, how
    )
    return repairs


def upload_repairs(registry: Registry) -> Any:
    """The `repair` an upload with `inertia_check: "repair"` gives `Registry.upload`: each
    link with an error repaired from its geometry, else to the nearest valid tensor."""

    def repair(inputs: CheckInputs) -> list[dict[str, Any]]:
        repairs: list[dict[str, Any]] = _isolated(registry, "repairs", inputs, "errors", "auto")
        return repairs

    return repair
