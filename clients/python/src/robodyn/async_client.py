"""`AsyncClient`: the asyncio/trio robodyn client, method for method the same as `Client`.

Its methods come by topic from `robodyn._methods` (each builds its request with
`robodyn._calls` and awaits it); its I/O is `robodyn._client.AsyncSender`.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import TracebackType

import httpx

from robodyn import outputs, transport
from robodyn import progress as _progress
from robodyn._methods.centroidal import AsyncCentroidalMethods
from robodyn._methods.contacts import AsyncContactMethods
from robodyn._methods.derivatives import AsyncDerivativeMethods
from robodyn._methods.equation_of_motion import AsyncEquationOfMotionMethods
from robodyn._methods.equations import AsyncEquationsMethods
from robodyn._methods.frames import AsyncFrameMethods
from robodyn._methods.health import AsyncHealthMethods
from robodyn._methods.identification import AsyncIdentificationMethods
from robodyn._methods.lagrangian import AsyncLagrangianMethods
from robodyn._methods.model_check import AsyncModelCheckMethods
from robodyn._methods.operational_space import AsyncOperationalSpaceMethods
from robodyn._methods.payload_capacity import AsyncPayloadCapacityMethods
from robodyn._methods.robots import AsyncRobotMethods
from robodyn._methods.simulation import AsyncSimulationMethods
from robodyn._methods.trajectories import AsyncTrajectoryMethods
from robodyn.request_options import Fill
from robodyn.stream import AsyncStream, stream_url


class AsyncClient(
    AsyncRobotMethods,
    AsyncModelCheckMethods,
    AsyncHealthMethods,
    AsyncEquationsMethods,
    AsyncEquationOfMotionMethods,
    AsyncLagrangianMethods,
    AsyncFrameMethods,
    AsyncOperationalSpaceMethods,
    AsyncDerivativeMethods,
    AsyncCentroidalMethods,
    AsyncSimulationMethods,
    AsyncContactMethods,
    AsyncPayloadCapacityMethods,
    AsyncTrajectoryMethods,
    AsyncIdentificationMethods,
):
    """An async client of a robodyn server; use it with `async with`, or await `aclose()`.

    `base_url`: the server (default: the injected client's base URL, else $ROBODYN_URL, else
    http://127.0.0.1:8000), or `unix:///path/robodyn.sock` for its Unix socket on this host
    (then large binary batches go through shared memory: `robodyn.shared_memory`).
    `api_key`: sent as `Authorization: Bearer <key>` (needed for uploads and deletions
    where the server has keys). `timeout`: seconds or an `httpx.Timeout`
    (default: 5 s to connect, 60 s for the rest). `http_client`: an `httpx.AsyncClient` to use
    instead of creating one (e.g. with a custom transport); its own timeouts apply, and
    `aclose()` leaves it open.
    `headers`: extra headers for every request.
    `binary`: send dynamics inputs and read answers in the binary form (a safetensors file of
    raw float64, see the server's docs/binary-format.md): None (default) for requests of
    `core.BINARY_FROM` numbers or more, True always, False never. Answers are bit for bit the
    same either way.
    `retry`, `array_type`, `progress` and `fill`: as for `Client`.
    """

    def __init__(
        self,
        base_url: str | None = None,
        *,
        api_key: str | None = None,
        timeout: transport.TimeoutLike = transport.DEFAULT_TIMEOUT,
        http_client: httpx.AsyncClient | None = None,
        headers: Mapping[str, str] | None = None,
        binary: bool | None = None,
        retry: transport.Retry | None = transport.DEFAULT_RETRY,
        array_type: outputs.ArrayType = "numpy",
        progress: _progress.Progress = None,
        fill: Fill | None = None,
    ) -> None:
        super().__init__(
            base_url,
            api_key=api_key,
            http_client=http_client,
            headers=headers,
            binary=binary,
            retry=retry,
            array_type=array_type,
            progress=progress,
            fill=fill,
        )
        self._http = http_client or httpx.AsyncClient(
            timeout=transport.timeout_of(timeout),
            limits=transport.DEFAULT_LIMITS,
            transport=transport.async_http_transport(self._settings),
        )

    async def __aenter__(self) -> AsyncClient:
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.aclose()

    def stream(self, robot_id: str, *, open_timeout: float | None = 10.0) -> AsyncStream:
        """A WebSocket stream of one robot: every dynamics method of this client, minus the
        `robot_id` argument, over one connection, answered in order (needs
        `pip install 'robodyn[stream]'`). Use it as an async context manager:
        `async with client.stream("ur5") as s: tau = await s.inverse_dynamics(q, v, a)`."""
        return AsyncStream(
            stream_url(self._settings.base_url, robot_id),
            robot_id,
            dict(self._settings.headers),
            self._settings.use_binary,
            open_timeout,
            self._settings.unix_socket,
        )
