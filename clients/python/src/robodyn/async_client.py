"""`AsyncClient`: the asyncio/trio robodyn client, method for method the same as `Client`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import TracebackType
from typing import Any, TypeVar

import httpx
import numpy as np

from robodyn import core, outputs, transport
from robodyn import progress as _progress
from robodyn.arrays import ArrayLike
from robodyn.contacts import (
    ContactDynamics,
    ContactInverseDynamics,
    ContactsLike,
    ContactTrajectory,
    ImpulseDynamics,
)
from robodyn.models import RobotInfo, RobotList
from robodyn.request_options import Fill, InertiaCheck, Integrator, ReferenceFrame, RootJoint, Task
from robodyn.results import (
    CenterOfMass,
    Centroidal,
    Energy,
    ForwardDynamicsDerivatives,
    FrameJacobian,
    Inertias,
    InverseDynamicsDerivatives,
    OperationalSpace,
    Trajectory,
)
from robodyn.stream import AsyncStream, stream_url
from robodyn.uploads import AssetValue, Source

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
    `binary`: send dynamics inputs and read answers in the binary form (a safetensors file of
    raw float64, see the server's docs/binary-format.md): None (default) for requests of
    `core.BINARY_FROM` numbers or more, True always, False never. Answers are bit for bit the
    same either way.
    `retry`, `array_type`, `progress` and `fill`: as for `Client`.
    """

    def __init__(self, base_url: str | None = None, *, api_key: str | None = None,
                 timeout: transport.TimeoutLike = transport.DEFAULT_TIMEOUT,
                 http_client: httpx.AsyncClient | None = None,
                 headers: Mapping[str, str] | None = None, binary: bool | None = None,
                 retry: transport.Retry | None = transport.DEFAULT_RETRY,
                 array_type: outputs.ArrayType = "numpy",
                 progress: _progress.Progress = None, fill: Fill | None = None) -> None:
        self._settings = transport.settings(base_url, api_key, http_client, headers, binary,
                                            fill)
        self._retry = retry
        self._array_type = outputs.check_array_type(array_type)
        self._progress = _progress.check(progress)
        self._owns_http = http_client is None
        self._http = http_client or httpx.AsyncClient(timeout=transport.timeout_of(timeout),
                                                 limits=transport.DEFAULT_LIMITS)

    @property
    def base_url(self) -> str:
        return self._settings.base_url

    async def _send(self, call: core.Call[T]) -> T:
        """Send `call` (in chunks with progress, retried as `retry` says); its answer in the
        client's array type."""
        if (self._progress is not None and call.split is not None and call.rows is not None
                and call.rows > _progress.CHUNK_STATES):
            result = await self._run(core.batch_chunks(call), call.rows, "states",
                                     self._progress)
        else:
            result = await self._fetch(call)
        return outputs.convert(result, self._array_type)

    async def _run(self, plan: _progress.Plan[T], total: int, unit: str,
                   report: _progress.Progress) -> T:
        """Send the calls of `plan` one after the other, reporting progress after each."""
        with _progress.Reporter(report, total, unit) as reporter:
            call, done = next(plan)
            while True:
                answer = await self._fetch(call)
                reporter(done)
                try:
                    call, done = plan.send(answer)
                except StopIteration as end:
                    return end.value  # type: ignore[no-any-return]

    async def _fetch(self, call: core.Call[T]) -> T:
        try:  # the first attempt outside stamina: ~30 µs less per call that succeeds
            return await self._fetch_once(call)
        except transport.RETRIED as exc:
            failure: Exception | None = exc
            if self._retry is None:
                raise
        async for attempt in transport.retry_context(call, self._retry):
            with attempt:
                if failure is not None:  # stamina decides on the first failure, and waits
                    first, failure = failure, None
                    raise first
                return await self._fetch_once(call)
        raise AssertionError("unreachable: the last attempt returns or raises")

    async def _fetch_once(self, call: core.Call[T]) -> T:
        url, headers, body = self._settings.prepare(call)
        content: Any = transport.parts_async(body) if isinstance(body, list) else body
        with transport.wrapped(call.method, url):
            async with self._http.stream(call.method, url, content=content,
                                        headers=headers) as response:
                length = core.binary_length(response)
                if length is None:
                    await response.aread()
                    received = None
                else:  # a large binary answer: straight into one buffer
                    receiver = core.Receiver(response, length)
                    async for chunk in response.aiter_raw():
                        receiver.add(chunk)
                    received = receiver.finish()
        return core.read_response(call, response, received)

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

    def stream(self, robot_id: str, *, open_timeout: float | None = 10.0) -> AsyncStream:
        """A WebSocket stream of one robot: every dynamics method of this client, minus the
        `robot_id` argument, over one connection, answered in order (needs
        `pip install 'robodyn[stream]'`). Use it as an async context manager:
        `async with client.stream("ur5") as s: tau = await s.inverse_dynamics(q, v, a)`."""
        return AsyncStream(stream_url(self.base_url, robot_id), robot_id,
                      dict(self._settings.headers), self._settings.use_binary, open_timeout)

    # The docstrings of the methods below are those of `robodyn.core` (see `share_docs`).

    async def health(self) -> dict[str, Any]:
        return await self._send(core.health())

    async def ready(self) -> bool:
        return await self._send(core.ready())

    async def robots(self) -> RobotList:
        return await self._send(core.robots())

    async def robot(self, robot_id: str) -> RobotInfo:
        return await self._send(core.robot(robot_id))

    async def upload(self, source: Source | None = None, *, urdf: Source | None = None,
                     mjcf: Source | None = None, xacro: Source | None = None,
                     xacro_args: Mapping[str, str] | None = None,
                     assets: Mapping[str, AssetValue] | None = None,
                     collect_assets: bool = True, root_joint: RootJoint = "fixed",
                     name: str | None = None, gravity: ArrayLike | None = None,
                     inertia_check: InertiaCheck | None = None,
                     locked_joints: Mapping[str, ArrayLike] | None = None) -> RobotInfo:
        """Store a model (text, file or directory; see `robodyn.core.upload`)."""
        return await self._send(core.upload(
            source, urdf=urdf, mjcf=mjcf, xacro=xacro, xacro_args=xacro_args, assets=assets,
            collect_assets=collect_assets, root_joint=root_joint, name=name, gravity=gravity,
            inertia_check=inertia_check, locked_joints=locked_joints))

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

    async def inverse_dynamics(self, robot_id: str, q: ArrayLike, v: ArrayLike, a: ArrayLike,
                               *, external_forces: Sequence[Mapping[str, Any]] | None = None
                               ) -> np.ndarray:
        return await self._send(core.inverse_dynamics(robot_id, q, v, a,
                                                      external_forces=external_forces))

    async def forward_dynamics(self, robot_id: str, q: ArrayLike, v: ArrayLike, tau: ArrayLike,
                               *, external_forces: Sequence[Mapping[str, Any]] | None = None
                               ) -> np.ndarray:
        return await self._send(core.forward_dynamics(robot_id, q, v, tau,
                                                      external_forces=external_forces))

    async def mass_matrix_inverse(self, robot_id: str, q: ArrayLike) -> np.ndarray:
        return await self._send(core.mass_matrix_inverse(robot_id, q))

    async def energy(self, robot_id: str, q: ArrayLike, v: ArrayLike) -> Energy:
        return await self._send(core.energy(robot_id, q, v))

    async def center_of_mass(self, robot_id: str, q: ArrayLike, v: ArrayLike | None = None
                             ) -> CenterOfMass:
        return await self._send(core.center_of_mass(robot_id, q, v))

    async def jacobian(self, robot_id: str, q: ArrayLike, frame: str, *,
                       reference_frame: ReferenceFrame = "local_world_aligned",
                       v: ArrayLike | None = None) -> FrameJacobian:
        return await self._send(core.jacobian(robot_id, q, frame,
                                              reference_frame=reference_frame, v=v))

    async def operational_space(self, robot_id: str, q: ArrayLike, frame: str, *,
                                v: ArrayLike | None = None,
                                reference_frame: ReferenceFrame = "local_world_aligned",
                                task: Task = "full", damping: float = 0.0
                                ) -> OperationalSpace:
        return await self._send(core.operational_space(robot_id, q, frame, v=v,
                                                       reference_frame=reference_frame,
                                                       task=task, damping=damping))

    async def inertias(self, robot_id: str) -> Inertias:
        return await self._send(core.inertias(robot_id))

    async def inverse_dynamics_derivatives(self, robot_id: str, q: ArrayLike, v: ArrayLike,
                                           a: ArrayLike) -> InverseDynamicsDerivatives:
        return await self._send(core.inverse_dynamics_derivatives(robot_id, q, v, a))

    async def forward_dynamics_derivatives(self, robot_id: str, q: ArrayLike, v: ArrayLike,
                                           tau: ArrayLike) -> ForwardDynamicsDerivatives:
        return await self._send(core.forward_dynamics_derivatives(robot_id, q, v, tau))

    async def centroidal(self, robot_id: str, q: ArrayLike, v: ArrayLike) -> Centroidal:
        return await self._send(core.centroidal(robot_id, q, v))

    async def simulate(self, robot_id: str, q: ArrayLike, v: ArrayLike, *, dt: float,
                       steps: int, tau: ArrayLike | Mapping[str, Any] | None = None,
                       controller: Mapping[str, Any] | None = None,
                       integrator: Integrator | None = None, contacts: ContactsLike | None = None,
                       damping: float = 0.0, progress: _progress.Progress = None
                       ) -> Trajectory | ContactTrajectory:
        report = _progress.check(progress) if progress is not None else self._progress
        if contacts is not None or report is None or steps <= _progress.CHUNK_STEPS:
            # A contact set holds its frames where the rollout starts: never chunked.
            return await self._send(core.simulate(robot_id, q, v, dt=dt, steps=steps, tau=tau,
                                                  controller=controller, integrator=integrator,
                                                  contacts=contacts, damping=damping))
        plan = core.simulate_chunks(robot_id, q, v, dt=dt, steps=steps, tau=tau,
                                    controller=controller, integrator=integrator)
        return outputs.convert(await self._run(plan, steps, "steps", report), self._array_type)

    # -- contacts ---------------------------------------------------------------------

    async def contact_dynamics(self, robot_id: str, q: ArrayLike, v: ArrayLike, tau: ArrayLike,
                         contacts: ContactsLike, *, damping: float = 0.0
                         ) -> ContactDynamics:
        return await self._send(core.contact_dynamics(robot_id, q, v, tau, contacts,
                                                damping=damping))

    async def contact_inverse_dynamics(self, robot_id: str, q: ArrayLike, v: ArrayLike,
                                 a: ArrayLike, contacts: ContactsLike, *,
                                 damping: float = 0.0) -> ContactInverseDynamics:
        return await self._send(core.contact_inverse_dynamics(robot_id, q, v, a, contacts,
                                                        damping=damping))

    async def impulse_dynamics(self, robot_id: str, q: ArrayLike, v: ArrayLike,
                         contacts: ContactsLike, *, restitution: float = 0.0,
                         damping: float = 0.0) -> ImpulseDynamics:
        return await self._send(core.impulse_dynamics(robot_id, q, v, contacts,
                                                restitution=restitution, damping=damping))

    # -- end of contacts --------------------------------------------------------------

    async def reduce(self, robot_id: str, locked_joints: Mapping[str, ArrayLike], *,
                     name: str | None = None) -> RobotInfo:
        return await self._send(core.reduce(robot_id, locked_joints, name=name))
