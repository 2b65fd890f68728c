"""Request and answer schemas of `trajectory-check` and `retime`, with units."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from service.api.schemas.common import (
    A_DESC,
    V_DESC,
    JointArray,
    JointVector,
    Number,
    QRequest,
    StrictRequest,
    joint_field,
)

Scale = Number


def _scale(what: str) -> Scale:
    return Field(
        1.0,
        gt=0,
        description=f"Fraction of the model's {what} limits to use "
        "(1 = the limits themselves; must be > 0).",
    )


class TrajectoryLimits(StrictRequest):
    """The limits a motion is checked or timed against, beyond the model's."""

    velocity_scale: Scale = _scale("velocity")
    effort_scale: Scale = _scale("effort")
    acceleration: list[Number | None] | None = Field(
        None,
        description="Joint acceleration limits, nv entries, rad/s² or m/s²: each a number > 0, "
        "or null (no limit on that joint); null: no acceleration limit at all.",
    )


Boundary = Literal["not-a-knot", "clamped", "natural"]


class TrajectoryCheckRequest(QRequest):
    """Samples of a motion: q [N][nq] at times t, optionally v and a [N][nv]."""

    t: list[Number] = Field(
        max_length=1_000_000,
        description="Sample times, s: N ≥ 2 numbers, strictly increasing, one per row of q.",
    )
    v: JointArray | None = joint_field(
        "Optional. " + V_DESC + " Without v and a they are the "
        "derivatives of the cubic spline through (t, q) with the "
        "`boundary` conditions (robots with nq = nv only).",
        None,
    )
    a: JointArray | None = joint_field("Optional. " + A_DESC, None)
    boundary: Boundary = Field(
        "not-a-knot",
        description="The end conditions of the cubic spline through (t, q) where v or a is "
        "absent: not-a-knot, clamped (zero velocity at both ends: a motion from rest to rest) "
        "or natural (zero acceleration at both ends).",
    )
    limits: TrajectoryLimits | None = Field(
        None,
        description="Limits beyond the model's: scales and optional acceleration limits, as "
        "retime takes them (not together with the top-level effort_scale or velocity_scale).",
    )
    effort_scale: Scale = _scale("effort")
    velocity_scale: Scale = _scale("velocity")
    friction: bool = Field(
        False,
        description="Add the joints' friction torque to τ, offset + "
        "coulomb ∘ sign(v) + viscous ∘ v: only for a robot stored by "
        "identification (its RobotInfo lists `friction`); any other robot "
        "is a 422.",
    )
    samples_per_interval: int = Field(
        4,
        ge=1,
        le=64,
        description=(
            "k: with the spline (v and a absent), the check also evaluates k − 1 evenly spaced "
            "points inside every interval, so that a limit broken between samples is found."
        ),
    )


class JointCheck(BaseModel):
    name: str
    effort_limit: float | None = Field(description="N·m or N, × effort_scale; null: none.")
    peak_effort: float = Field(description="max |τ| over every evaluated point, N·m or N.")
    effort_ratio: float | None = Field(description="peak_effort ÷ effort_limit.")
    velocity_limit: float | None = Field(description="rad/s or m/s, × velocity_scale.")
    peak_velocity: float = Field(description="max |v| over every evaluated point.")
    velocity_ratio: float | None = Field(description="peak_velocity ÷ velocity_limit.")
    acceleration_limit: float | None = Field(
        description="rad/s² or m/s², from limits.acceleration; null: none."
    )
    peak_acceleration: float = Field(description="max |a| over every evaluated point.")
    acceleration_ratio: float | None = Field(description="peak_acceleration ÷ acceleration_limit.")
    lower: float | None = Field(description="Lower position limit, rad or m; null: none.")
    upper: float | None = Field(description="Upper position limit, rad or m; null: none.")
    min_position: float | None = Field(description="Smallest q over the evaluated points.")
    max_position: float | None = Field(description="Largest q over the evaluated points.")
    rms_effort: float = Field(
        description="√(∫ τ² dt ÷ duration) by the trapezoidal rule over the evaluated points, "
        "N·m or N: the torque that heats the motor as the motion does."
    )
    peak_power: float = Field(description="max |τ v| over every evaluated point, W.")
    peak_force: float = Field(
        description="max ‖f‖ over every evaluated point, N: f the force of the wrench the "
        "joint transmits to its child body (RNEA's data.f, in the joint frame)."
    )
    peak_moment: float = Field(
        description="max ‖n‖, N·m: n the moment of that wrench about the joint frame's origin."
    )
    peak_axial_force: float = Field(
        description="max |f · s|, N, s the joint's unit axis: a revolute joint's bearing "
        "thrust, a prismatic joint's |τ|."
    )
    peak_bending_moment: float = Field(
        description="max ‖n − (n · s) s‖, N·m: the moment the bearings carry across the axis "
        "(a revolute joint's τ is n · s)."
    )


class Violation(BaseModel):
    joint: str
    kind: Literal["effort", "velocity", "acceleration", "position"]
    t_start: float = Field(description="Time of the first evaluated point beyond the limit, s.")
    t_end: float = Field(description="Time of the last one of that run, s.")
    worst: float = Field(description="The value farthest beyond the limit (signed).")
    limit: float = Field(description="That limit (signed; after the scales).")


class Work(BaseModel):
    positive: float = Field(description="∫ max(τᵀv, 0) dt, J.")
    negative: float = Field(description="∫ min(τᵀv, 0) dt, J.")


class TrajectoryCheckAnswer(BaseModel):
    feasible: bool = Field(description="No violation at any evaluated point.")
    tau: JointVector = Field(description="τ at the samples, [N][nv], N·m or N.")
    v: JointVector = Field(description="v at the samples (given, or the spline's), [N][nv].")
    joints: list[JointCheck] = Field(description="Every 1-DoF joint, in model order.")
    violations: list[Violation] = Field(
        description="Every run of evaluated points beyond a limit, by start time."
    )
    work: Work


class RetimeRequest(StrictRequest):
    """A path through waypoints [K][nq] to time."""

    waypoints: JointArray = Field(
        description=(
            "K ≥ 2 configurations (at most 1000), each nq numbers (rad or m), or objects keyed by "
            "joint name: the path is the clamped cubic spline through them, parameterised by the "
            "cumulative joint-space distance; the motion starts and ends at rest."
        )
    )
    limits: TrajectoryLimits | None = Field(
        None, description="Limits beyond the model's: scales and optional acceleration limits."
    )
    sample_dt: Number = Field(0.01, gt=0, description="Time between answer samples, s.")


class RetimeAnswer(BaseModel):
    duration: float = Field(description="Duration of the motion, s.")
    t: list[float] = Field(description="Sample times, every sample_dt from 0, and the end, s.")
    q: JointVector = Field(description="Configurations at the samples, [M][nq].")
    v: JointVector = Field(description="Velocities, [M][nv], rad/s or m/s.")
    a: JointVector = Field(
        description="Accelerations, [M][nv], rad/s² or m/s² (they jump "
        "where the path acceleration of TOPP-RA's intervals does)."
    )
    tau: JointVector = Field(description="Joint torques, [M][nv], N·m or N.")
    check: TrajectoryCheckAnswer = Field(description="The trajectory check of the samples.")
