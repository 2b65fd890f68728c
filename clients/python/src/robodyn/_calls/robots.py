"""Request builders of the robot routes: the robot list, one robot, uploads, deletions,
reductions, variants and body inertias. (The clients' docstrings describe them.)"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any
from urllib.parse import urlencode

import numpy as np

from robodyn._calls.request import ROBOT, route_call
from robodyn.arrays import ArrayLike, gravity_vector
from robodyn.core import Call
from robodyn.errors import InputError
from robodyn.models import RobotInfo, RobotList
from robodyn.payloads import PayloadsLike, payloads_body
from robodyn.request_options import InertiaCheck, RootJoint
from robodyn.results import Inertias
from robodyn.uploads import AssetValue, Source, upload_body


def robots(*, page_size: int | None = None) -> Call[RobotList]:
    # the first page: the client method follows `next_cursor` with `robot_page`
    return robot_page(page_size)


def robot_page(limit: int | None = None, cursor: str | None = None) -> Call[RobotList]:
    # the largest limit is the server's (1000): a larger one is its 422
    if limit is not None and (isinstance(limit, bool) or not isinstance(limit, int) or limit < 1):
        raise InputError(f"limit is {limit!r}; give a whole number of robots, at least 1")
    if cursor is not None and not isinstance(cursor, str):
        raise TypeError(f"cursor must be a str (a page's next_cursor), not {type(cursor).__name__}")
    query = {k: v for k, v in (("limit", limit), ("cursor", cursor)) if v is not None}
    path = "/v1/robots" + (f"?{urlencode(query)}" if query else "")
    call = route_call("GET", "/v1/robots", lambda status, body: RobotList.from_json(body))
    return replace(call, path=path)


def robot(robot_id: str) -> Call[RobotInfo]:
    return route_call("GET", ROBOT, lambda status, body: RobotInfo.from_json(body), robot_id)


def _created(status: int, body: Any) -> RobotInfo:
    return RobotInfo.from_json(body, created=status == 201)


def upload(
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
) -> Call[RobotInfo]:
    body = upload_body(
        source, urdf=urdf, mjcf=mjcf, xacro=xacro, assets=assets, collect_assets=collect_assets
    )
    if xacro_args is not None:
        body["xacro_args"] = {str(k): str(v) for k, v in xacro_args.items()}
    body["root_joint"] = root_joint
    if name is not None:
        body["name"] = name
    if gravity is not None:
        body["gravity"] = gravity_vector(gravity)
    if inertia_check is not None:
        body["inertia_check"] = inertia_check
    if locked_joints is not None:
        body["locked_joints"] = _locked_joints(locked_joints)
    return route_call("POST", "/v1/robots", _created, body=body)


def delete(robot_id: str) -> Call[None]:
    return route_call("DELETE", ROBOT, lambda status, body: None, robot_id, idempotent=False)


def reduce(
    robot_id: str, locked_joints: Mapping[str, ArrayLike], *, name: str | None = None
) -> Call[RobotInfo]:
    body: dict[str, Any] = {"locked_joints": _locked_joints(locked_joints)}
    if name is not None:
        body["name"] = name
    return route_call("POST", f"{ROBOT}/reduce", _created, robot_id, body)


def variant(
    robot_id: str,
    *,
    payloads: PayloadsLike | None = None,
    locked_joints: Mapping[str, ArrayLike] | None = None,
    name: str | None = None,
    inertias: Mapping[str, Any] | None = None,
) -> Call[RobotInfo]:
    body: dict[str, Any] = payloads_body(payloads)
    if locked_joints is not None:
        body["locked_joints"] = _locked_joints(locked_joints)
    if inertias is not None:
        body["inertias"] = _inertias(inertias)
    if not body:
        raise InputError("a variant needs payloads, locked_joints, inertias or several")
    if name is not None:
        body["name"] = name
    return route_call("POST", f"{ROBOT}/variants", _created, robot_id, body)


def _inertias(inertias: Mapping[str, Any]) -> dict[str, Any]:
    """The `inertias` repair of a variant: {"links": names | "errors" | "all", "from":
    "geometry" | "nearest_valid"}."""
    if not isinstance(inertias, Mapping) or set(inertias) != {"links", "from"}:
        raise InputError(
            'inertias must be {"links": [names] | "errors" | "all", '
            '"from": "geometry" | "nearest_valid"}'
        )
    links = inertias["links"]
    if not isinstance(links, str):
        links = [str(name) for name in links]
    return {"links": links, "from": str(inertias["from"])}


def _locked_joints(locked: Mapping[str, ArrayLike]) -> dict[str, Any]:
    """Locked joint positions as JSON: joint name → a number or a list of numbers (finite)."""
    if not isinstance(locked, Mapping) or not locked:
        raise InputError("locked_joints must be a non-empty mapping of joint name to position")
    out: dict[str, Any] = {}
    for name, value in locked.items():
        if not isinstance(name, str):
            raise InputError(
                f"locked_joints keys must be joint names (str), not {type(name).__name__}"
            )
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (ValueError, TypeError):
            raise InputError(
                f"locked_joints['{name}'] must be a number or a list of numbers"
            ) from None
        if arr.ndim > 1 or arr.size == 0:
            raise InputError(
                f"locked_joints['{name}'] must be a number or a non-empty 1-D list of numbers"
            )
        if not np.all(np.isfinite(arr)):
            raise InputError(f"locked_joints['{name}'] must be finite")
        out[name] = float(arr) if arr.ndim == 0 else arr.tolist()
    return out


def inertias(robot_id: str) -> Call[Inertias]:
    return route_call(
        "GET", f"{ROBOT}/inertias", lambda status, body: Inertias.from_json(body), robot_id
    )
