"""Request options beyond joint states, checked locally: choices, frame names, external forces
and simulation."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Literal, get_args

import numpy as np

from robodyn.arrays import joint_array, joint_input
from robodyn.errors import InputError

ReferenceFrame = Literal["local_world_aligned", "local", "world"]
"""Axes and origin of 6-vectors and Jacobians (Pinocchio's): the frame's origin with world
axes (default), the frame's origin and axes, or the world origin and axes."""
Task = Literal["full", "linear", "angular"]
"""Rows of an operational-space task: all 6, the 3 linear ones or the 3 angular ones."""
Integrator = Literal["semi-implicit-euler", "rk4"]
"""Integrator of `simulate`."""
RootJoint = Literal["fixed", "free-flyer", "planar"]
"""How an uploaded model's root link is attached to the world."""
InertiaCheck = Literal["reject", "warn", "repair"]
"""What an upload does with implausible inertias."""
Fill = Literal["neutral"] | str
"""How name-keyed inputs fill the joints they leave out: "neutral" or the name of one of the
robot's reference configurations (`RobotInfo.raw["reference_configurations"]`) for q; v, a
and τ of missing joints are zero."""

REFERENCE_FRAMES: tuple[str, ...] = get_args(ReferenceFrame)
TASKS: tuple[str, ...] = get_args(Task)
INTEGRATORS: tuple[str, ...] = get_args(Integrator)


def choice(name: str, value: Any, allowed: tuple[str, ...]) -> str:
    """`value` if it is one of `allowed`; else an InputError listing them."""
    if not isinstance(value, str) or value not in allowed:
        raise InputError(f"{name} must be one of {', '.join(map(repr, allowed))}, not {value!r}")
    return value


def frame_name(frame: Any) -> str:
    """A frame name argument: a non-empty str (the server checks that the robot has it)."""
    if not isinstance(frame, str):
        raise TypeError(
            f"frame must be a str (a name from robot(id).frame_names), not {type(frame).__name__}"
        )
    if not frame:
        raise InputError("frame is empty; robot(id).frame_names lists the valid names")
    return frame


def frame_options(frame: Any, reference_frame: Any) -> dict[str, str]:
    """The `frame` and `reference_frame` body members of a frame's quantity (jacobian,
    operational-space), checked."""
    return {
        "frame": frame_name(frame),
        "reference_frame": choice("reference_frame", reference_frame, REFERENCE_FRAMES),
    }


def _json(value: Any) -> Any:
    return value.tolist() if isinstance(value, np.ndarray) else value


def external_forces(forces: Sequence[Mapping[str, Any]] | None) -> dict[str, Any]:
    """The `external_forces` body member (empty when None): each force a mapping with "frame"
    (str), "wrench" (6 numbers, or (N, 6) for one per state) and optional "reference_frame"."""
    if forces is None:
        return {}
    if isinstance(forces, Mapping) or not isinstance(forces, Sequence):
        raise InputError(
            "external_forces must be a list of {'frame', 'wrench', 'reference_frame'} mappings"
        )
    out = []
    for k, force in enumerate(forces):
        where = f"external_forces[{k}]"
        if not isinstance(force, Mapping):
            raise InputError(f"{where} must be a mapping with 'frame' and 'wrench'")
        unknown = set(force) - {"frame", "wrench", "reference_frame"}
        if unknown or "frame" not in force or "wrench" not in force:
            raise InputError(
                f"{where} needs 'frame' and 'wrench' and may have 'reference_frame', nothing else"
            )
        if not isinstance(force["frame"], str):
            raise InputError(f"{where}['frame'] must be a frame name (str)")
        wrench = joint_array(f"{where}['wrench']", force["wrench"])
        if wrench.shape[-1] != 6:
            raise InputError(
                f"{where}['wrench'] must have 6 entries (force then torque), or "
                f"shape (N, 6); it has shape {wrench.shape}"
            )
        item: dict[str, Any] = {"frame": force["frame"], "wrench": wrench.tolist()}
        if "reference_frame" in force:
            if force["reference_frame"] not in REFERENCE_FRAMES:
                raise InputError(
                    f"{where}['reference_frame'] must be one of {', '.join(REFERENCE_FRAMES)}"
                )
            item["reference_frame"] = force["reference_frame"]
        out.append(item)
    return {"external_forces": out}


def _gain(name: str, value: Any) -> Any:
    if isinstance(value, int | float) and not isinstance(value, bool):
        if not np.isfinite(value):
            raise InputError(f"{name} must be finite")
        return float(value)
    return _json(joint_input(name, value))


def simulation(
    dt: float,
    steps: int,
    tau: Any,
    controller: Mapping[str, Any] | None,
    integrator: Integrator | None,
) -> dict[str, Any]:
    """The non-state members of a simulate body, checked."""
    if isinstance(dt, bool) or not isinstance(dt, int | float) or not np.isfinite(dt) or dt <= 0:
        raise InputError("dt must be a positive number of seconds")
    if isinstance(steps, bool) or not isinstance(steps, int | np.integer) or steps < 1:
        raise InputError("steps must be a positive integer")
    body: dict[str, Any] = {"dt": float(dt), "steps": int(steps)}
    if tau is not None and controller is not None:
        raise InputError("give tau or controller, not both")
    if tau is not None:
        body["tau"] = _json(joint_input("tau", tau))
    if controller is not None:
        if not isinstance(controller, Mapping):
            raise InputError(
                "controller must be a mapping like {'type': 'pd', 'kp': ..., "
                "'kd': ..., 'q_target': ...}"
            )
        pd = dict(controller)
        for gain in ("kp", "kd"):
            if gain in pd:
                pd[gain] = _gain(f"controller['{gain}']", pd[gain])
        if "q_target" in pd:
            pd["q_target"] = _json(joint_input("controller['q_target']", pd["q_target"]))
        body["controller"] = pd
    if integrator is not None:
        if integrator not in INTEGRATORS:
            raise InputError(f"integrator must be one of {', '.join(INTEGRATORS)}")
        body["integrator"] = integrator
    return body
