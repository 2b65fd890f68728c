"""Payloads: rigid bodies held by a frame, composed into a copy of a robot's model.

A payload is a rigid body of mass m (kg, > 0) whose centre of mass is at c (m, in the axes and
from the origin of the frame that holds it) and whose rotational inertia about c is I_c
(3×3, kg·m², symmetric positive semidefinite, in the frame's axes). It is welded to the body
that carries the frame: with the frame's placement X (the pose of the frame in its parent
joint's frame, Pinocchio's `frame.placement`) and j the frame's parent joint,

    inertias[j] ← inertias[j] + X · Inertia(m, c, I_c)

(spatial inertias add; `X · ` maps one from the frame into the joint's frame: the parallel-axis
theorem and a rotation of I_c). Every quantity of the new model (M, C, g, τ, the contact
forces, the total mass and the centre of mass) includes the payload. A payload on a frame
attached to the world (a fixed base's base link) is added to the fixed mass and moves nothing.

This module composes payloads that were already checked (`service.dynamics.payloads` checks a
request's); the shared model is never mutated: the composition is made on a copy.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from service.registry.robot import Robot


@dataclass(frozen=True)
class PlacedPayload:
    """One checked payload: `frame` (a frame name of the robot that will carry it), `mass` (kg,
    finite, > 0), `center_of_mass` (3 numbers, m, in the frame) and `inertia` (3×3 as nested
    tuples, kg·m², about the centre of mass, in the frame's axes)."""

    frame: str
    mass: float
    center_of_mass: tuple[float, float, float]
    inertia: tuple[tuple[float, ...], ...]

    def spatial_inertia(self) -> Any:
        """The payload's spatial inertia in the frame (`pin.Inertia`)."""
        return pin.Inertia(
            self.mass,
            np.array(self.center_of_mass, dtype=float),
            np.array(self.inertia, dtype=float),
        )

    def as_dict(self) -> dict[str, Any]:
        """The payload as the API writes it (for records, ids and `modifications`)."""
        return {
            "frame": self.frame,
            "mass": self.mass,
            "center_of_mass": list(self.center_of_mass),
            "inertia": [list(row) for row in self.inertia],
        }

    @classmethod
    def from_dict(cls, value: dict[str, Any]) -> PlacedPayload:
        """The inverse of `as_dict` (a stored record's payload, checked when it was stored)."""
        com = [float(x) for x in value["center_of_mass"]]
        rows = tuple(tuple(float(x) for x in row) for row in value["inertia"])
        return cls(str(value["frame"]), float(value["mass"]), (com[0], com[1], com[2]), rows)

    def key(self) -> tuple[Any, ...]:
        """A hashable, totally ordered form (frame, m, c, I) for caches and canonical ids."""
        return (self.frame, self.mass, self.center_of_mass, self.inertia)


def canonical(payloads: Sequence[PlacedPayload]) -> tuple[PlacedPayload, ...]:
    """The payloads in a canonical order (by frame, then numbers): spatial inertias add, so
    the order of a request does not change the robot, and it does not change ids either."""
    return tuple(sorted(payloads, key=PlacedPayload.key))


def composed_model(robot: Robot, payloads: Sequence[PlacedPayload]) -> Any:
    """A copy of `robot.model` whose bodies carry `payloads` (see the module docstring); the
    robot's own model is untouched. Every frame must be a frame of the robot (checked)."""
    model = pin.Model(robot.model)
    for payload in payloads:
        fid = robot.frame_ids.get(payload.frame)
        if fid is None:  # checked by the caller; a record naming no frame is corrupt
            raise ValueError(f"robot '{robot.id}' has no frame '{payload.frame}'")
        frame = model.frames[fid]
        joint = int(frame.parentJoint)
        model.inertias[joint] = model.inertias[joint] + frame.placement.act(
            payload.spatial_inertia()
        )
    return model


def carrying(
    robot: Robot,
    payloads: Sequence[PlacedPayload],
    *,
    robot_id: str | None = None,
    name: str | None = None,
    source: str | None = None,
    parent: str | None = None,
    modifications: dict[str, Any] | None = None,
) -> Robot:
    """A new `Robot` like `robot` whose model carries `payloads` (a copy: `robot` is never
    changed), with its own Data pool. Everything but the inertias carries over (joints,
    frames, limits, configurations, visuals). Without `robot_id` it keeps the robot's id, so
    error messages name the robot the request named."""
    return derived(
        robot,
        composed_model(robot, payloads),
        robot_id=robot_id,
        name=name,
        source=source,
        parent=parent,
        modifications=modifications,
    )


def derived(
    robot: Robot,
    model: Any,
    *,
    robot_id: str | None = None,
    name: str | None = None,
    source: str | None = None,
    parent: str | None = None,
    modifications: dict[str, Any] | None = None,
) -> Robot:
    """A `Robot` with `model` (same joints and frames as `robot.model`) and everything else of
    `robot`: configurations, contact frames, warnings, visuals, the q convention."""
    return Robot(
        id=robot.id if robot_id is None else robot_id,
        name=robot.name if name is None else name,
        source=robot.source if source is None else source,
        root_joint=robot.root_joint,
        model=model,
        reference_configurations=dict(robot.reference_configurations),
        default_configuration=robot.default_configuration,
        contact_frames=[dict(c) for c in robot.contact_frames],
        warnings=list(robot.warnings),
        origin=robot.origin,
        visuals=robot.visuals,
        asset_paths=dict(robot.asset_paths),
        mujoco_qpos=robot.mujoco_qpos,
        parent=parent if parent is not None else robot.parent,
        modifications=modifications if modifications is not None else robot.modifications,
    )
