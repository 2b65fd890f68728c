"""`Client`: the blocking robodyn client (one pooled `httpx.Client`, reused for every call).

Its methods come by topic from `robodyn._methods` (each builds its request with
`robodyn._calls` and sends it); its I/O is `robodyn._client.SyncSender`.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import TracebackType

import httpx

from robodyn import outputs, transport
from robodyn import progress as _progress
from robodyn._methods.centroidal import CentroidalMethods
from robodyn._methods.contacts import ContactMethods
from robodyn._methods.derivatives import DerivativeMethods
from robodyn._methods.equation_of_motion import EquationOfMotionMethods
from robodyn._methods.equations import EquationsMethods
from robodyn._methods.frames import FrameMethods
from robodyn._methods.health import HealthMethods
from robodyn._methods.identification import IdentificationMethods
from robodyn._methods.lagrangian import LagrangianMethods
from robodyn._methods.model_check import ModelCheckMethods
from robodyn._methods.operational_space import OperationalSpaceMethods
from robodyn._methods.payload_capacity import PayloadCapacityMethods
from robodyn._methods.robots import RobotMethods
from robodyn._methods.simulation import SimulationMethods
from robodyn._methods.trajectories import TrajectoryMethods
from robodyn.request_options import Fill
from robodyn.stream import Stream, stream_url


class Client(
    RobotMethods,
    ModelCheckMethods,
    HealthMethods,
    EquationsMethods,
    EquationOfMotionMethods,
    LagrangianMethods,
    FrameMethods,
    OperationalSpaceMethods,
    DerivativeMethods,
    CentroidalMethods,
    SimulationMethods,
    ContactMethods,
    PayloadCapacityMethods,
    TrajectoryMethods,
    IdentificationMethods,
):
    """A blocking client of a robodyn server; use it as a context manager, or call `close()`.

    `base_url`: the server (default: the injected client's base URL, else $ROBODYN_URL, else
    http://127.0.0.1:8000), or `unix:///path/robodyn.sock` for its Unix socket on this host
    (then large binary batches go through shared memory: `robodyn.shared_memory`).
    `api_key`: sent as `Authorization: Bearer <key>` (needed for uploads and deletions
    where the server has keys). `timeout`: seconds or an `httpx.Timeout`
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

    def __init__(
        self,
        base_url: str | None = None,
        *,
        api_key: str | None = None,
        timeout: transport.TimeoutLike = transport.DEFAULT_TIMEOUT,
        http_client: httpx.Client | None = None,
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
        self._http = http_client or httpx.Client(
            timeout=transport.timeout_of(timeout),
            limits=transport.DEFAULT_LIMITS,
            transport=transport.http_transport(self._settings),
        )

    def __enter__(self) -> Client:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def stream(self, robot_id: str, *, open_timeout: float | None = 10.0) -> Stream:
        """A WebSocket stream of one robot: every dynamics method of this client, minus the
        `robot_id` argument, over one connection, answered in order (needs
        `pip install 'robodyn[stream]'`). Use it as a context manager:
        `with client.stream("ur5") as s: tau = s.inverse_dynamics(q, v, a)`."""
        return Stream(
            stream_url(self._settings.base_url, robot_id),
            robot_id,
            dict(self._settings.headers),
            self._settings.use_binary,
            open_timeout,
            self._settings.unix_socket,
        )
