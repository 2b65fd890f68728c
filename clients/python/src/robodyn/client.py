"""`Client`: the blocking robodyn client (one pooled `httpx.Client`, reused for every call)."""

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
    `binary`: send dynamics inputs and read answers in the binary form (a safetensors file of
    raw float64, see the server's docs/binary-format.md): None (default) for requests of
    `core.BINARY_FROM` numbers or more, True always, False never. Answers are bit for bit the
    same either way.
    `retry`: how requests the server could not answer (503, failed connections) are retried
    (`transport.Retry`: by default 5 attempts within 30 s, honouring `Retry-After`); None
    never retries.
    `array_type`: "numpy" (default) or "torch" for answers as float64 torch tensors (PyTorch
    is imported only then).
    `progress`: a callable `(done, total)` or True (a tqdm bar) to send large batches in chunks
    of `progress.CHUNK_STATES` states and simulations in chunks of `progress.CHUNK_STEPS`
    steps, reporting after each; None (default) sends each call as one request.
    `fill`: for inputs keyed by joint name (mappings, ROS JointState-like objects), how the
    server fills the joints they leave out: "neutral" or a reference configuration's name for
    q, zero for v, a and τ. None (default): every joint must be named.
    """

    def __init__(self, base_url: str | None = None, *, api_key: str | None = None,
                 timeout: transport.TimeoutLike = transport.DEFAULT_TIMEOUT,
                 http_client: httpx.Client | None = None,
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
        self._http = http_client or httpx.Client(timeout=transport.timeout_of(timeout),
                                                 limits=transport.DEFAULT_LIMITS)

    @property
    def base_url(self) -> str:
        return self._settings.base_url

    def _send(self, call: core.Call[T]) -> T:
        """Send `call` (in chunks with progress, retried as `retry` says); its answer in the
        client's array type."""
        if (self._progress is not None and call.split is not None and call.rows is not None
                and call.rows > _progress.CHUNK_STATES):
            result = self._run(core.batch_chunks(call), call.rows, "states", self._progress)
        else:
            result = self._fetch(call)
        return outputs.convert(result, self._array_type)

    def _run(self, plan: _progress.Plan[T], total: int, unit: str,
             report: _progress.Progress) -> T:
        """Send the calls of `plan` one after the other, reporting progress after each."""
        with _progress.Reporter(report, total, unit) as reporter:
            call, done = next(plan)
            while True:
                answer = self._fetch(call)
                reporter(done)
                try:
                    call, done = plan.send(answer)
                except StopIteration as end:
                    return end.value  # type: ignore[no-any-return]

    def _fetch(self, call: core.Call[T]) -> T:
        try:  # the first attempt outside stamina: ~30 µs less per call that succeeds
            return self._fetch_once(call)
        except transport.RETRIED as exc:
            failure: Exception | None = exc
            if self._retry is None:
                raise
        for attempt in transport.retry_context(call, self._retry):
            with attempt:
                if failure is not None:  # stamina decides on the first failure, and waits
                    first, failure = failure, None
                    raise first
                return self._fetch_once(call)
        raise AssertionError("unreachable: the last attempt returns or raises")

    def _fetch_once(self, call: core.Call[T]) -> T:
        url, headers, body = self._settings.prepare(call)
        content: Any = body  # bytes, or parts (bytes and memoryviews) httpx sends in turn
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
               collect_assets: bool = True, root_joint: RootJoint = "fixed",
               name: str | None = None, gravity: ArrayLike | None = None,
               inertia_check: InertiaCheck | None = None,
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
                 reference_frame: ReferenceFrame = "local_world_aligned",
                 v: ArrayLike | None = None) -> FrameJacobian:
        return self._send(core.jacobian(robot_id, q, frame, reference_frame=reference_frame,
                                        v=v))

    def operational_space(self, robot_id: str, q: ArrayLike, frame: str, *,
                          v: ArrayLike | None = None,
                          reference_frame: ReferenceFrame = "local_world_aligned",
                          task: Task = "full", damping: float = 0.0) -> OperationalSpace:
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

    def simulate(self, robot_id: str, q: ArrayLike, v: ArrayLike, *, dt: float,
                 steps: int, tau: ArrayLike | Mapping[str, Any] | None = None,
                 controller: Mapping[str, Any] | None = None,
                 integrator: Integrator | None = None, contacts: ContactsLike | None = None,
                 damping: float = 0.0, progress: _progress.Progress = None
                 ) -> Trajectory | ContactTrajectory:
        report = _progress.check(progress) if progress is not None else self._progress
        if contacts is not None or report is None or steps <= _progress.CHUNK_STEPS:
            # A contact set holds its frames where the rollout starts: never chunked.
            return self._send(core.simulate(robot_id, q, v, dt=dt, steps=steps, tau=tau,
                                            controller=controller, integrator=integrator,
                                            contacts=contacts, damping=damping))
        plan = core.simulate_chunks(robot_id, q, v, dt=dt, steps=steps, tau=tau,
                                    controller=controller, integrator=integrator)
        return outputs.convert(self._run(plan, steps, "steps", report), self._array_type)

    # -- contacts ---------------------------------------------------------------------

    def contact_dynamics(self, robot_id: str, q: ArrayLike, v: ArrayLike, tau: ArrayLike,
                         contacts: ContactsLike, *, damping: float = 0.0
                         ) -> ContactDynamics:
        return self._send(core.contact_dynamics(robot_id, q, v, tau, contacts,
                                                damping=damping))

    def contact_inverse_dynamics(self, robot_id: str, q: ArrayLike, v: ArrayLike,
                                 a: ArrayLike, contacts: ContactsLike, *,
                                 damping: float = 0.0) -> ContactInverseDynamics:
        return self._send(core.contact_inverse_dynamics(robot_id, q, v, a, contacts,
                                                        damping=damping))

    def impulse_dynamics(self, robot_id: str, q: ArrayLike, v: ArrayLike,
                         contacts: ContactsLike, *, restitution: float = 0.0,
                         damping: float = 0.0) -> ImpulseDynamics:
        return self._send(core.impulse_dynamics(robot_id, q, v, contacts,
                                                restitution=restitution, damping=damping))

    # -- end of contacts --------------------------------------------------------------

    def reduce(self, robot_id: str, locked_joints: Mapping[str, ArrayLike], *,
               name: str | None = None) -> RobotInfo:
        return self._send(core.reduce(robot_id, locked_joints, name=name))
