"""Client methods of trajectories: check a sampled motion against the robot's limits, and
time a path through waypoints optimally (`Client` and `AsyncClient` inherit them)."""

from __future__ import annotations

from robodyn import progress as _progress
from robodyn._calls import trajectories as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.arrays import ArrayLike
from robodyn.payloads import PayloadsLike
from robodyn.trajectories import Retimed, TrajectoryCheck


class TrajectoryMethods(SyncSender):
    """The trajectory methods of `Client`."""

    def trajectory_check(
        self,
        robot_id: str,
        t: ArrayLike,
        q: ArrayLike,
        *,
        v: ArrayLike | None = None,
        a: ArrayLike | None = None,
        effort_scale: float = 1.0,
        velocity_scale: float = 1.0,
        acceleration: ArrayLike | None = None,
        boundary: str = "not-a-knot",
        samples_per_interval: int = 4,
        friction: bool = False,
        payloads: PayloadsLike | None = None,
        progress: _progress.Progress = None,
    ) -> TrajectoryCheck:
        """`TrajectoryCheck`: does the motion sampled at times `t` (shape (N,), s, strictly
        increasing) with configurations `q` (shape (N, nq)) stay within the robot's effort, velocity
        and position limits (effort and velocity limits × `effort_scale`, `velocity_scale`)
        and the joint `acceleration` limits (nv,) where given (an entry None or NaN: no
        limit on that joint)? `v` and `a` (N, nv): where absent, the derivatives of the
        cubic spline through (t, q) with the `boundary` conditions "not-a-knot", "clamped"
        (zero velocity at both ends: a motion from rest to rest) or "natural" (robots with
        nq = nv), and `samples_per_interval` − 1 points inside every interval are evaluated
        too, so that a limit broken between samples is found. τ = M(q) a + C(q, v) v + g(q)
        at every evaluated point. The answer: `feasible`, `tau` and `v` at the samples
        (N, nv), `joints` (`JointCheck`: limits, peaks of |τ|, |v|, |a|, ratios),
        `violations` (`Violation`: joint, kind, t_start, t_end, worst, limit) and `work`
        (`Work`: positive and negative, J). Raises `ValidationError` for non-increasing
        times, `DimensionMismatchError` for rows that do not match. `friction=True` adds the
        joints' identified friction to τ (a robot stored by `identify`; any other robot is a
        `ValidationError`). `payloads`: rigid bodies the robot holds (`Payload`s), added to
        its model for this call. `progress`: a callable (done, total) or True for a tqdm bar
        (the client's by default): the server streams the count of evaluated points as it
        checks (`robodyn.progress`).
        """
        return self._send(
            calls.trajectory_check(
                robot_id,
                t,
                q,
                v=v,
                a=a,
                effort_scale=effort_scale,
                velocity_scale=velocity_scale,
                acceleration=acceleration,
                boundary=boundary,
                samples_per_interval=samples_per_interval,
                friction=friction,
                payloads=payloads,
            ),
            progress,
        )

    def retime(
        self,
        robot_id: str,
        waypoints: ArrayLike,
        *,
        velocity_scale: float = 1.0,
        effort_scale: float = 1.0,
        acceleration: ArrayLike | None = None,
        sample_dt: float = 0.01,
        payloads: PayloadsLike | None = None,
        progress: _progress.Progress = None,
    ) -> Retimed:
        """`Retimed`: the time-optimal motion, from rest to rest, along the clamped cubic
        spline through `waypoints` of shape (K, nq) (parameterised by cumulative joint-space
        distance),
        under the velocity limits × `velocity_scale`, the effort limits × `effort_scale` and
        the joint `acceleration` limits (nv,) where given (an entry None or NaN: no limit on
        that joint): `duration` (s), samples every
        `sample_dt` s and at the end — `t` (M,), `q` (M, nq), `v`, `a`, `tau` (M, nv) — and
        its `check` (a `TrajectoryCheck`). The motion is within every limit everywhere, not
        only at samples (1e-6 relative), and at most 1 % slower than the optimum
        (docs/trajectories.md says how). Raises
        `InfeasiblePathError` for a path no timing can follow (its `body` names the joint,
        the waypoint and the path fraction) and `UnsupportedModelError` for a robot with
        joints other than revolute or prismatic. `payloads`: rigid bodies the robot holds
        (`Payload`s), added to its model for this call. `progress`: a callable (done, total)
        or True for a tqdm bar (the client's by default): the server streams its steps (path,
        TOPP-RA and correction, samples and their check; `robodyn.progress`).
        """
        return self._send(
            calls.retime(
                robot_id,
                waypoints,
                velocity_scale=velocity_scale,
                effort_scale=effort_scale,
                acceleration=acceleration,
                sample_dt=sample_dt,
                payloads=payloads,
            ),
            progress,
        )


class AsyncTrajectoryMethods(AsyncSender):
    """The trajectory methods of `AsyncClient`."""

    async def trajectory_check(
        self,
        robot_id: str,
        t: ArrayLike,
        q: ArrayLike,
        *,
        v: ArrayLike | None = None,
        a: ArrayLike | None = None,
        effort_scale: float = 1.0,
        velocity_scale: float = 1.0,
        acceleration: ArrayLike | None = None,
        boundary: str = "not-a-knot",
        samples_per_interval: int = 4,
        friction: bool = False,
        payloads: PayloadsLike | None = None,
        progress: _progress.Progress = None,
    ) -> TrajectoryCheck:
        """`TrajectoryCheck`: does the motion sampled at times `t` (shape (N,), s, strictly
        increasing) with configurations `q` (shape (N, nq)) stay within the robot's effort, velocity
        and position limits (effort and velocity limits × `effort_scale`, `velocity_scale`)
        and the joint `acceleration` limits (nv,) where given (an entry None or NaN: no
        limit on that joint)? `v` and `a` (N, nv): where absent, the derivatives of the
        cubic spline through (t, q) with the `boundary` conditions "not-a-knot", "clamped"
        (zero velocity at both ends: a motion from rest to rest) or "natural" (robots with
        nq = nv), and `samples_per_interval` − 1 points inside every interval are evaluated
        too, so that a limit broken between samples is found. τ = M(q) a + C(q, v) v + g(q)
        at every evaluated point. The answer: `feasible`, `tau` and `v` at the samples
        (N, nv), `joints` (`JointCheck`: limits, peaks of |τ|, |v|, |a|, ratios),
        `violations` (`Violation`: joint, kind, t_start, t_end, worst, limit) and `work`
        (`Work`: positive and negative, J). Raises `ValidationError` for non-increasing
        times, `DimensionMismatchError` for rows that do not match. `friction=True` adds the
        joints' identified friction to τ (a robot stored by `identify`; any other robot is a
        `ValidationError`). `payloads`: rigid bodies the robot holds (`Payload`s), added to
        its model for this call. `progress`: a callable (done, total) or True for a tqdm bar
        (the client's by default): the server streams the count of evaluated points as it
        checks (`robodyn.progress`).
        """
        return await self._send(
            calls.trajectory_check(
                robot_id,
                t,
                q,
                v=v,
                a=a,
                effort_scale=effort_scale,
                velocity_scale=velocity_scale,
                acceleration=acceleration,
                boundary=boundary,
                samples_per_interval=samples_per_interval,
                friction=friction,
                payloads=payloads,
            ),
            progress,
        )

    async def retime(
        self,
        robot_id: str,
        waypoints: ArrayLike,
        *,
        velocity_scale: float = 1.0,
        effort_scale: float = 1.0,
        acceleration: ArrayLike | None = None,
        sample_dt: float = 0.01,
        payloads: PayloadsLike | None = None,
        progress: _progress.Progress = None,
    ) -> Retimed:
        """`Retimed`: the time-optimal motion, from rest to rest, along the clamped cubic
        spline through `waypoints` of shape (K, nq) (parameterised by cumulative joint-space
        distance),
        under the velocity limits × `velocity_scale`, the effort limits × `effort_scale` and
        the joint `acceleration` limits (nv,) where given (an entry None or NaN: no limit on
        that joint): `duration` (s), samples every
        `sample_dt` s and at the end — `t` (M,), `q` (M, nq), `v`, `a`, `tau` (M, nv) — and
        its `check` (a `TrajectoryCheck`). The motion is within every limit everywhere, not
        only at samples (1e-6 relative), and at most 1 % slower than the optimum
        (docs/trajectories.md says how). Raises
        `InfeasiblePathError` for a path no timing can follow (its `body` names the joint,
        the waypoint and the path fraction) and `UnsupportedModelError` for a robot with
        joints other than revolute or prismatic. `payloads`: rigid bodies the robot holds
        (`Payload`s), added to its model for this call. `progress`: a callable (done, total)
        or True for a tqdm bar (the client's by default): the server streams its steps (path,
        TOPP-RA and correction, samples and their check; `robodyn.progress`).
        """
        return await self._send(
            calls.retime(
                robot_id,
                waypoints,
                velocity_scale=velocity_scale,
                effort_scale=effort_scale,
                acceleration=acceleration,
                sample_dt=sample_dt,
                payloads=payloads,
            ),
            progress,
        )
