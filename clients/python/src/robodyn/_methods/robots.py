"""Client methods of the robot routes: the robot list, one robot, uploads, deletions,
reductions, variants and body inertias (`Client` and `AsyncClient` inherit them)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from robodyn._calls import robots as calls
from robodyn._client import AsyncSender, SyncSender
from robodyn.arrays import ArrayLike
from robodyn.models import RobotInfo, RobotList
from robodyn.payloads import PayloadsLike
from robodyn.request_options import InertiaCheck, RootJoint
from robodyn.results import Inertias
from robodyn.uploads import AssetValue, Source


class RobotMethods(SyncSender):
    """The robot methods of `Client`."""

    def robots(self, *, page_size: int | None = None) -> RobotList:
        """Every robot the server serves, catalog and uploads: a `RobotList` of `RobotSummary`
        (with `unavailable`: catalog robots the server could not load, and why), gathered by
        following the list's pages (`page_size` robots each, the server's default if None).
        """
        pages = [self._send(calls.robots(page_size=page_size))]
        while pages[-1].next_cursor is not None:
            pages.append(self._send(calls.robot_page(page_size, pages[-1].next_cursor)))
        return RobotList.joined(pages)

    def robot_page(self, limit: int | None = None, cursor: str | None = None) -> RobotList:
        """One page of the robot list: at most `limit` robots (the server's default if None,
        at most 1000) from `cursor` (None: the first page; else the `next_cursor` of the page
        before), and the page's `next_cursor` (None on the last page). The catalog comes
        first, then the stored models by id.
        """
        return self._send(calls.robot_page(limit, cursor))

    def robot(self, robot_id: str) -> RobotInfo:
        """The `RobotInfo` of one robot: sizes nq and nv, joint layout and limits, frames, gravity,
        total mass, reference configurations and physical findings. Raises `RobotNotFoundError` for
        an unknown id.
        """
        return self._send(calls.robot(robot_id))

    def upload(
        self,
        source: Source | None = None,
        *,
        urdf: Source | None = None,
        mjcf: Source | None = None,
        xacro: Source | None = None,
        xacro_args: Mapping[str, str] | None = None,
        assets: Mapping[str, AssetValue] | None = None,
        collect_assets: bool = True,
        root_joint: RootJoint = "fixed",
        name: str | None = None,
        gravity: ArrayLike | None = None,
        inertia_check: InertiaCheck | None = None,
        locked_joints: Mapping[str, ArrayLike] | None = None,
    ) -> RobotInfo:
        """Store a model on the server and return its `RobotInfo` (`created` tells whether it is
        new). The id is derived from the content, options and assets, so the same upload gives the
        same id.

        `source` is the description: its text (str or UTF-8 bytes; URDF, MJCF or xacro, told apart
        by its root element), a path to its file, or a directory holding it (the one description at
        its top, else the one in its tree — a ROS package layout `pkg/urdf/robot.urdf` is found).
        From a path, the files it references (meshes, included MJCF or xacro files, YAML) are
        collected and sent as assets (see `robodyn.uploads`; `collect_assets=False` sends none);
        `assets` (key → bytes, text or a path) adds or replaces some. `urdf=`, `mjcf=` or `xacro=`
        name the format instead of `source`. `xacro_args` sets a xacro's arguments (strings).

        `root_joint` is "fixed", "free-flyer" or "planar" (an MJCF whose top body has a free joint
        is free-flying by itself); `gravity` is 3 numbers in m/s² (default: an MJCF's own `<option
        gravity>`, else [0, 0, -9.81]); `inertia_check` "reject" (default), "warn" or "repair"
        (each link with an error repaired, listed in `warnings`) for implausible inertias.
        `locked_joints` (joint name → position, see `reduce`) stores only the
        reduced model. Raises `InvalidModelError` for a description that is not a usable model.
        """
        return self._send(
            calls.upload(
                source,
                urdf=urdf,
                mjcf=mjcf,
                xacro=xacro,
                xacro_args=xacro_args,
                assets=assets,
                collect_assets=collect_assets,
                root_joint=root_joint,
                name=name,
                gravity=gravity,
                inertia_check=inertia_check,
                locked_joints=locked_joints,
            )
        )

    def delete(self, robot_id: str) -> None:
        """Delete an uploaded model. Raises `CatalogRobotError` for a catalog robot and
        `RobotNotFoundError` for an unknown id.
        """
        return self._send(calls.delete(robot_id))

    def reduce(
        self, robot_id: str, locked_joints: Mapping[str, ArrayLike], *, name: str | None = None
    ) -> RobotInfo:
        """Store the reduced model of any robot (catalog or upload) with `locked_joints` locked and
        return its `RobotInfo` (a new durable id; `created` tells whether it is new, and
        `raw["reduced_from"]` names the base robot and each locked joint's q entries).
        `locked_joints` maps joint names to positions: a number (rad or m) for revolute and
        prismatic joints, an angle or [cos θ, sin θ] for continuous ones, [x, y, z, qx, qy, qz, qw]
        for a free-flyer, [x, y, θ] or [x, y, cos θ, sin θ] for a planar joint, [qx, qy, qz, qw]
        for a spherical one ([qw, qx, qy, qz], MuJoCo's qpos order, for a model uploaded as MJCF).
        Raises `ValidationError` for an unknown joint (all listed) or a value of the wrong size,
        `InvalidConfigurationError` for a value outside the joint's limits, and `InvalidModelError`
        when every moving joint would be locked.
        """
        return self._send(calls.reduce(robot_id, locked_joints, name=name))

    def variant(
        self,
        robot_id: str,
        *,
        payloads: PayloadsLike | None = None,
        locked_joints: Mapping[str, ArrayLike] | None = None,
        name: str | None = None,
        inertias: Mapping[str, Any] | None = None,
    ) -> RobotInfo:
        """Store a variant of any robot (catalog, upload or variant) and return its `RobotInfo`: the
        robot with the link inertials of `inertias` repaired ({"links": [names] | "errors" | "all",
        "from": "geometry" | "nearest_valid"}: see `model_check`), carrying `payloads` (`Payload`s
        or mappings: rigid bodies added to the bodies that carry their frames), then with
        `locked_joints` locked (as in `reduce`); at least one of the three. Its id derives from the
        parent's id and the modifications (the same on every server, whatever the payloads' order;
        `created` tells whether it is new), its `parent` and `modifications` say what it derives
        from, and it works on after the parent is deleted. Locked joints alone give `reduce`'s model
        and id. Raises `ValidationError` for a bad payload (named by its index) or joint,
        `UnknownFrameError` for a payload's frame the robot lacks."""
        return self._send(
            calls.variant(
                robot_id,
                payloads=payloads,
                locked_joints=locked_joints,
                name=name,
                inertias=inertias,
            )
        )

    def inertias(self, robot_id: str) -> Inertias:
        """`Inertias` of every body (one per joint): mass (kg), centre of mass (shape (3,), m) and
        inertia at it and at the joint (shape (3, 3), kg·m²), principal moments and axes, all in
        the joint's frame; and `total_mass`. Raises `RobotNotFoundError` for an unknown id.
        """
        return self._send(calls.inertias(robot_id))


class AsyncRobotMethods(AsyncSender):
    """The robot methods of `AsyncClient`."""

    async def robots(self, *, page_size: int | None = None) -> RobotList:
        """Every robot the server serves, catalog and uploads: a `RobotList` of `RobotSummary`
        (with `unavailable`: catalog robots the server could not load, and why), gathered by
        following the list's pages (`page_size` robots each, the server's default if None).
        """
        pages = [await self._send(calls.robots(page_size=page_size))]
        while pages[-1].next_cursor is not None:
            pages.append(await self._send(calls.robot_page(page_size, pages[-1].next_cursor)))
        return RobotList.joined(pages)

    async def robot_page(self, limit: int | None = None, cursor: str | None = None) -> RobotList:
        """One page of the robot list: at most `limit` robots (the server's default if None,
        at most 1000) from `cursor` (None: the first page; else the `next_cursor` of the page
        before), and the page's `next_cursor` (None on the last page). The catalog comes
        first, then the stored models by id.
        """
        return await self._send(calls.robot_page(limit, cursor))

    async def robot(self, robot_id: str) -> RobotInfo:
        """The `RobotInfo` of one robot: sizes nq and nv, joint layout and limits, frames, gravity,
        total mass, reference configurations and physical findings. Raises `RobotNotFoundError` for
        an unknown id.
        """
        return await self._send(calls.robot(robot_id))

    async def upload(
        self,
        source: Source | None = None,
        *,
        urdf: Source | None = None,
        mjcf: Source | None = None,
        xacro: Source | None = None,
        xacro_args: Mapping[str, str] | None = None,
        assets: Mapping[str, AssetValue] | None = None,
        collect_assets: bool = True,
        root_joint: RootJoint = "fixed",
        name: str | None = None,
        gravity: ArrayLike | None = None,
        inertia_check: InertiaCheck | None = None,
        locked_joints: Mapping[str, ArrayLike] | None = None,
    ) -> RobotInfo:
        """Store a model on the server and return its `RobotInfo` (`created` tells whether it is
        new). The id is derived from the content, options and assets, so the same upload gives the
        same id.

        `source` is the description: its text (str or UTF-8 bytes; URDF, MJCF or xacro, told apart
        by its root element), a path to its file, or a directory holding it (the one description at
        its top, else the one in its tree — a ROS package layout `pkg/urdf/robot.urdf` is found).
        From a path, the files it references (meshes, included MJCF or xacro files, YAML) are
        collected and sent as assets (see `robodyn.uploads`; `collect_assets=False` sends none);
        `assets` (key → bytes, text or a path) adds or replaces some. `urdf=`, `mjcf=` or `xacro=`
        name the format instead of `source`. `xacro_args` sets a xacro's arguments (strings).

        `root_joint` is "fixed", "free-flyer" or "planar" (an MJCF whose top body has a free joint
        is free-flying by itself); `gravity` is 3 numbers in m/s² (default: an MJCF's own `<option
        gravity>`, else [0, 0, -9.81]); `inertia_check` "reject" (default), "warn" or "repair"
        (each link with an error repaired, listed in `warnings`) for implausible inertias.
        `locked_joints` (joint name → position, see `reduce`) stores only the
        reduced model. Raises `InvalidModelError` for a description that is not a usable model.
        """
        return await self._send(
            calls.upload(
                source,
                urdf=urdf,
                mjcf=mjcf,
                xacro=xacro,
                xacro_args=xacro_args,
                assets=assets,
                collect_assets=collect_assets,
                root_joint=root_joint,
                name=name,
                gravity=gravity,
                inertia_check=inertia_check,
                locked_joints=locked_joints,
            )
        )

    async def delete(self, robot_id: str) -> None:
        """Delete an uploaded model. Raises `CatalogRobotError` for a catalog robot and
        `RobotNotFoundError` for an unknown id.
        """
        return await self._send(calls.delete(robot_id))

    async def reduce(
        self, robot_id: str, locked_joints: Mapping[str, ArrayLike], *, name: str | None = None
    ) -> RobotInfo:
        """Store the reduced model of any robot (catalog or upload) with `locked_joints` locked and
        return its `RobotInfo` (a new durable id; `created` tells whether it is new, and
        `raw["reduced_from"]` names the base robot and each locked joint's q entries).
        `locked_joints` maps joint names to positions: a number (rad or m) for revolute and
        prismatic joints, an angle or [cos θ, sin θ] for continuous ones, [x, y, z, qx, qy, qz, qw]
        for a free-flyer, [x, y, θ] or [x, y, cos θ, sin θ] for a planar joint, [qx, qy, qz, qw]
        for a spherical one ([qw, qx, qy, qz], MuJoCo's qpos order, for a model uploaded as MJCF).
        Raises `ValidationError` for an unknown joint (all listed) or a value of the wrong size,
        `InvalidConfigurationError` for a value outside the joint's limits, and `InvalidModelError`
        when every moving joint would be locked.
        """
        return await self._send(calls.reduce(robot_id, locked_joints, name=name))

    async def variant(
        self,
        robot_id: str,
        *,
        payloads: PayloadsLike | None = None,
        locked_joints: Mapping[str, ArrayLike] | None = None,
        name: str | None = None,
        inertias: Mapping[str, Any] | None = None,
    ) -> RobotInfo:
        """Store a variant of any robot (catalog, upload or variant) and return its `RobotInfo`: the
        robot with the link inertials of `inertias` repaired ({"links": [names] | "errors" | "all",
        "from": "geometry" | "nearest_valid"}: see `model_check`), carrying `payloads` (`Payload`s
        or mappings: rigid bodies added to the bodies that carry their frames), then with
        `locked_joints` locked (as in `reduce`); at least one of the three. Its id derives from the
        parent's id and the modifications (the same on every server, whatever the payloads' order;
        `created` tells whether it is new), its `parent` and `modifications` say what it derives
        from, and it works on after the parent is deleted. Locked joints alone give `reduce`'s model
        and id. Raises `ValidationError` for a bad payload (named by its index) or joint,
        `UnknownFrameError` for a payload's frame the robot lacks."""
        return await self._send(
            calls.variant(
                robot_id,
                payloads=payloads,
                locked_joints=locked_joints,
                name=name,
                inertias=inertias,
            )
        )

    async def inertias(self, robot_id: str) -> Inertias:
        """`Inertias` of every body (one per joint): mass (kg), centre of mass (shape (3,), m) and
        inertia at it and at the joint (shape (3, 3), kg·m²), principal moments and axes, all in
        the joint's frame; and `total_mass`. Raises `RobotNotFoundError` for an unknown id.
        """
        return await self._send(calls.inertias(robot_id))
