"""`AsyncClient`: the asyncio/trio robodyn client, method for method the same as `Client`."""

from __future__ import annotations

import os
from collections.abc import Mapping
from types import TracebackType
from typing import Any, TypeVar

import httpx
import numpy as np

from robodyn import core, transport
from robodyn.arrays import ArrayLike
from robodyn.models import RobotInfo, RobotList

T = TypeVar("T")


@core.share_docs
class AsyncClient:
    """An async client of a robodyn server; use it with `async with`, or await `aclose()`.

    `base_url`: the server (default: the injected client's base URL, else $ROBODYN_URL, else
    http://127.0.0.1:8000). `api_key`: sent as `Authorization: Bearer <key>` (needed for uploads
    and deletions where the server has keys). `timeout`: seconds or an `httpx.Timeout`
    (default: 5 s to connect, 60 s for the rest). `http_client`: an `httpx.AsyncClient` to use
    instead of creating one (e.g. with a custom transport); its own timeouts apply, and
    `aclose()` leaves it open.
    `headers`: extra headers for every request.
    """

    def __init__(self, base_url: str | None = None, *, api_key: str | None = None,
                 timeout: transport.TimeoutLike = transport.DEFAULT_TIMEOUT,
                 http_client: httpx.AsyncClient | None = None,
                 headers: Mapping[str, str] | None = None) -> None:
        self._settings = transport.settings(base_url, api_key, http_client, headers)
        self._owns_http = http_client is None
        self._http = http_client or httpx.AsyncClient(timeout=transport.timeout_of(timeout),
                                                 limits=transport.DEFAULT_LIMITS)

    @property
    def base_url(self) -> str:
        return self._settings.base_url

    async def _send(self, call: core.Call[T]) -> T:
        url, headers, content = self._settings.prepare(call)
        with transport.wrapped(call.method, url):
            response = await self._http.request(call.method, url, content=content, headers=headers)
        return core.read_response(call, response)

    async def aclose(self) -> None:
        """Close the connection pool (not an injected `http_client`)."""
        if self._owns_http:
            await self._http.aclose()

    async def __aenter__(self) -> AsyncClient:
        return self

    async def __aexit__(self, exc_type: type[BaseException] | None,
                        exc: BaseException | None, tb: TracebackType | None) -> None:
        await self.aclose()

    def __repr__(self) -> str:
        return f"AsyncClient({self.base_url!r})"

    # The docstrings of the methods below are those of `robodyn.core` (see `share_docs`).

    async def health(self) -> dict[str, Any]:
        return await self._send(core.health())

    async def ready(self) -> bool:
        return await self._send(core.ready())

    async def robots(self) -> RobotList:
        return await self._send(core.robots())

    async def robot(self, robot_id: str) -> RobotInfo:
        return await self._send(core.robot(robot_id))

    async def upload(self, urdf: str | bytes | os.PathLike[str] | None = None, *,
                     mjcf: str | bytes | os.PathLike[str] | None = None,
                     root_joint: str = "fixed", name: str | None = None,
                     gravity: ArrayLike | None = None, inertia_check: str | None = None,
                     locked_joints: Mapping[str, ArrayLike] | None = None) -> RobotInfo:
        return await self._send(core.upload(urdf, mjcf=mjcf, root_joint=root_joint, name=name,
                                            gravity=gravity, inertia_check=inertia_check,
                                            locked_joints=locked_joints))

    async def delete(self, robot_id: str) -> None:
        return await self._send(core.delete(robot_id))

    async def mass_matrix(self, robot_id: str, q: ArrayLike) -> np.ndarray:
        return await self._send(core.mass_matrix(robot_id, q))

    async def gravity(self, robot_id: str, q: ArrayLike) -> np.ndarray:
        return await self._send(core.gravity(robot_id, q))

    async def coriolis(self, robot_id: str, q: ArrayLike, v: ArrayLike
                       ) -> tuple[np.ndarray, np.ndarray]:
        return await self._send(core.coriolis(robot_id, q, v))

    async def nonlinear_effects(self, robot_id: str, q: ArrayLike, v: ArrayLike) -> np.ndarray:
        return await self._send(core.nonlinear_effects(robot_id, q, v))

    async def inverse_dynamics(self, robot_id: str, q: ArrayLike, v: ArrayLike, a: ArrayLike
                               ) -> np.ndarray:
        return await self._send(core.inverse_dynamics(robot_id, q, v, a))

    async def forward_dynamics(self, robot_id: str, q: ArrayLike, v: ArrayLike, tau: ArrayLike
                               ) -> np.ndarray:
        return await self._send(core.forward_dynamics(robot_id, q, v, tau))

    async def reduce(self, robot_id: str, locked_joints: Mapping[str, ArrayLike], *,
                     name: str | None = None) -> RobotInfo:
        return await self._send(core.reduce(robot_id, locked_joints, name=name))
