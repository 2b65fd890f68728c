"""`Client`: the blocking robodyn client (one pooled `httpx.Client`, reused for every call)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import TracebackType
from typing import Any, TypeVar

import httpx
import numpy as np

from robodyn import core, transport
from robodyn.arrays import ArrayLike
from robodyn.models import RobotInfo, RobotList
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
from robodyn.stream import Stream, stream_url
from robodyn.uploads import AssetValue, Source

T = TypeVar("T")


@core.share_docs
class Client:
    """A blocking client of a robodyn server; use it as a context manager, or call `close()`.

    `base_url`: the server (default: the injected client's base URL, else $ROBODYN_URL, else
    http://127.0.0.1:8000). `api_key`: sent as `Authorization: Bearer <key>` (needed for uploads
    and deletions where the server has keys). `timeout`: seconds or an `httpx.Timeout`
    (default: 5 s to connect, 60 s for the rest). `http_client`: an `httpx.Client` to use
    instead of creating one (e.g. with a custom transport); its own timeouts apply, and
    `close()` leaves it open.
    `headers`: extra headers for every request.
    `binary`: send dynamics inputs and read answers in the binary form (raw float64, see the
    server's docs/binary-format.md): None (default) for requests of `core.BINARY_FROM` numbers
    or more, True always, False never. Answers are bit for bit the same either way.
    """

    def __init__(self, base_url: str | None = None, *, api_key: str | None = None,
                 timeout: transport.TimeoutLike = transport.DEFAULT_TIMEOUT,
                 http_client: httpx.Client | None = None,
                 headers: Mapping[str, str] | None = None, binary: bool | None = None) -> None:
        self._settings = transport.settings(base_url, api_key, http_client, headers, binary)
        self._owns_http = http_client is None
        self._http = http_client or httpx.Client(timeout=transport.timeout_of(timeout),
                                                 limits=transport.DEFAULT_LIMITS)

    @property
    def base_url(self) -> str:
        return self._settings.base_url

    def _send(self, call: core.Call[T]) -> T:
        url, headers, content = self._settings.prepare(call)
        with transport.wrapped(call.method, url), self._http.stream(
                call.method, url, content=content, headers=headers) as response:
            length = core.binary_length(response)
            if length is None:
                response.read()
                received = None
            else:  # a large binary answer: straight into one buffer
                receiver = core.Receiver(response, length)
                for chunk in response.iter_raw():
                    receiver.add(chunk)
                received = receiver.finish()
        return core.read_response(call, response, received)

    def close(self) -> None:
        """Close the connection pool (not an injected `http_client`)."""
        if self._owns_http:
            self._http.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Client({self.base_url!r})"

    def stream(self, robot_id: str, *, open_timeout: float | None = 10.0) -> Stream:
        """A WebSocket stream of one robot: every dynamics method of this client, minus the
        `robot_id` argument, over one connection, answered in order (needs
        `pip install 'robodyn[stream]'`). Use it as a context manager:
        `with client.stream("ur5") as s: tau = s.inverse_dynamics(q, v, a)`."""
        return Stream(stream_url(self.base_url, robot_id), robot_id,
                      dict(self._settings.headers), self._settings.use_binary, open_timeout)

    # The docstrings of the methods below are those of `robodyn.core` (see `share_docs`).

    def health(self) -> dict[str, Any]:
        return self._send(core.health())

    def ready(self) -> bool:
        return self._send(core.ready())

    def robots(self) -> RobotList:
        return self._send(core.robots())

    def robot(self, robot_id: str) -> RobotInfo:
        return self._send(core.robot(robot_id))

    def upload(self, source: Source | None = None, *, urdf: Source | None = None,
               mjcf: Source | None = None, xacro: Source | None = None,
               xacro_args: Mapping[str, str] | None = None,
               assets: Mapping[str, AssetValue] | None = None,
               collect_assets: bool = True, root_joint: str = "fixed",
               name: str | None = None, gravity: ArrayLike | None = None,
               inertia_check: str | None = None,
               locked_joints: Mapping[str, ArrayLike] | None = None) -> RobotInfo:
        """Store a model (text, file or directory; see `robodyn.core.upload`)."""
        return self._send(core.upload(
            source, urdf=urdf, mjcf=mjcf, xacro=xacro, xacro_args=xacro_args, assets=assets,
            collect_assets=collect_assets, root_joint=root_joint, name=name, gravity=gravity,
            inertia_check=inertia_check, locked_joints=locked_joints))

    def delete(self, robot_id: str) -> None:
        return self._send(core.delete(robot_id))

    def mass_matrix(self, robot_id: str, q: ArrayLike) -> np.ndarray:
        return self._send(core.mass_matrix(robot_id, q))

    def gravity(self, robot_id: str, q: ArrayLike) -> np.ndarray:
        return self._send(core.gravity(robot_id, q))

    def coriolis(self, robot_id: str, q: ArrayLike, v: ArrayLike
                 ) -> tuple[np.ndarray, np.ndarray]:
        return self._send(core.coriolis(robot_id, q, v))

    def nonlinear_effects(self, robot_id: str, q: ArrayLike, v: ArrayLike) -> np.ndarray:
        return self._send(core.nonlinear_effects(robot_id, q, v))

    def inverse_dynamics(self, robot_id: str, q: ArrayLike, v: ArrayLike, a: ArrayLike, *,
                         external_forces: Sequence[Mapping[str, Any]] | None = None
                         ) -> np.ndarray:
        return self._send(core.inverse_dynamics(robot_id, q, v, a,
                                                external_forces=external_forces))

    def forward_dynamics(self, robot_id: str, q: ArrayLike, v: ArrayLike, tau: ArrayLike, *,
                         external_forces: Sequence[Mapping[str, Any]] | None = None
                         ) -> np.ndarray:
        return self._send(core.forward_dynamics(robot_id, q, v, tau,
                                                external_forces=external_forces))

    def mass_matrix_inverse(self, robot_id: str, q: ArrayLike) -> np.ndarray:
        return self._send(core.mass_matrix_inverse(robot_id, q))

    def energy(self, robot_id: str, q: ArrayLike, v: ArrayLike) -> Energy:
        return self._send(core.energy(robot_id, q, v))

    def center_of_mass(self, robot_id: str, q: ArrayLike, v: ArrayLike | None = None
                       ) -> CenterOfMass:
        return self._send(core.center_of_mass(robot_id, q, v))

    def jacobian(self, robot_id: str, q: ArrayLike, frame: str, *,
                 reference_frame: str = "local_world_aligned", v: ArrayLike | None = None
                 ) -> FrameJacobian:
        return self._send(core.jacobian(robot_id, q, frame, reference_frame=reference_frame,
                                        v=v))

    def operational_space(self, robot_id: str, q: ArrayLike, frame: str, *,
                          v: ArrayLike | None = None,
                          reference_frame: str = "local_world_aligned", task: str = "full",
                          damping: float = 0.0) -> OperationalSpace:
        return self._send(core.operational_space(robot_id, q, frame, v=v,
                                                 reference_frame=reference_frame, task=task,
                                                 damping=damping))

    def inertias(self, robot_id: str) -> Inertias:
        return self._send(core.inertias(robot_id))

    def inverse_dynamics_derivatives(self, robot_id: str, q: ArrayLike, v: ArrayLike,
                                     a: ArrayLike) -> InverseDynamicsDerivatives:
        return self._send(core.inverse_dynamics_derivatives(robot_id, q, v, a))

    def forward_dynamics_derivatives(self, robot_id: str, q: ArrayLike, v: ArrayLike,
                                     tau: ArrayLike) -> ForwardDynamicsDerivatives:
        return self._send(core.forward_dynamics_derivatives(robot_id, q, v, tau))

    def centroidal(self, robot_id: str, q: ArrayLike, v: ArrayLike) -> Centroidal:
        return self._send(core.centroidal(robot_id, q, v))

    def simulate(self, robot_id: str, q: ArrayLike, v: ArrayLike, *, dt: float, steps: int,
                 tau: ArrayLike | Mapping[str, Any] | None = None,
                 controller: Mapping[str, Any] | None = None,
                 integrator: str | None = None) -> Trajectory:
        return self._send(core.simulate(robot_id, q, v, dt=dt, steps=steps, tau=tau,
                                        controller=controller, integrator=integrator))

    def reduce(self, robot_id: str, locked_joints: Mapping[str, ArrayLike], *,
               name: str | None = None) -> RobotInfo:
        return self._send(core.reduce(robot_id, locked_joints, name=name))
