"""Client methods of the service's health: liveness and readiness (`Client` and `AsyncClient`
inherit them)."""

from __future__ import annotations

from typing import Any

from robodyn._calls import health as calls
from robodyn._client import AsyncSender, SyncSender


class HealthMethods(SyncSender):
    """The health methods of `Client`."""

    def health(self) -> dict[str, Any]:
        """Liveness: the server's `/health/live` answer, `{"status": "ok"}`."""
        return self._send(calls.health())

    def ready(self) -> bool:
        """Readiness: True once the server has loaded its catalog and can compute, False before."""
        return self._send(calls.ready())


class AsyncHealthMethods(AsyncSender):
    """The health methods of `AsyncClient`."""

    async def health(self) -> dict[str, Any]:
        """Liveness: the server's `/health/live` answer, `{"status": "ok"}`."""
        return await self._send(calls.health())

    async def ready(self) -> bool:
        """Readiness: True once the server has loaded its catalog and can compute, False before."""
        return await self._send(calls.ready())
