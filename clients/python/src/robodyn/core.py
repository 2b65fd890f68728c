"""The I/O-free core shared by `Client` and `AsyncClient`: requests are built and answers read here.

Each public function checks its arguments, and returns a `Call`: the HTTP method, the path, the
JSON body and how to read the answer. The two clients only send a Call and hand the response to
`read_response`; that is the only difference between them. The docstrings here are the clients'
method docstrings.

Shapes: `nq` is the length of q and `nv` that of v, a and τ (see `RobotInfo.joints`). A 1-D input
is one state; 2-D inputs of shape (N, n) are N states and every output gains a leading axis N.
Units: SI — q in rad or m, v in rad/s or m/s, a in rad/s² or m/s², τ in N·m or N.
"""

from __future__ import annotations

import json
import numbers
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Generic, TypeVar
from urllib.parse import quote

import httpx
import numpy as np

from robodyn import binary, outputs, progress, request_options
from robodyn.arrays import (
    ArrayLike,
    answer_array,
    batch_rows,
    gravity_vector,
    joint_input,
    joint_states,
    to_json,
)
from robodyn.contacts import (
    ContactDynamics,
    ContactInverseDynamics,
    ContactsLike,
    ContactTrajectory,
    ImpulseDynamics,
    contacts_body,
    nonnegative,
)
from robodyn.errors import APIError, InputError, ResponseFormatError, error_class
from robodyn.models import RobotInfo, RobotList
from robodyn.request_options import (
    REFERENCE_FRAMES,
    TASKS,
    InertiaCheck,
    Integrator,
    ReferenceFrame,
    RootJoint,
    Task,
)
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
from robodyn.uploads import AssetValue, Source, upload_body

T = TypeVar("T")

ROUTES: dict[str, tuple[str, str]] = {
    "health": ("GET", "/health/live"),
    "ready": ("GET", "/health/ready"),
    "robots": ("GET", "/v1/robots"),
    "robot": ("GET", "/v1/robots/{robot_id}"),
    "upload": ("POST", "/v1/robots"),
    "delete": ("DELETE", "/v1/robots/{robot_id}"),
    "mass_matrix": ("POST", "/v1/robots/{robot_id}/mass-matrix"),
    "gravity": ("POST", "/v1/robots/{robot_id}/gravity"),
    "coriolis": ("POST", "/v1/robots/{robot_id}/coriolis"),
    "nonlinear_effects": ("POST", "/v1/robots/{robot_id}/nonlinear-effects"),
    "inverse_dynamics": ("POST", "/v1/robots/{robot_id}/inverse-dynamics"),
    "forward_dynamics": ("POST", "/v1/robots/{robot_id}/forward-dynamics"),
    "mass_matrix_inverse": ("POST", "/v1/robots/{robot_id}/mass-matrix-inverse"),
    "energy": ("POST", "/v1/robots/{robot_id}/energy"),
    "center_of_mass": ("POST", "/v1/robots/{robot_id}/center-of-mass"),
    "jacobian": ("POST", "/v1/robots/{robot_id}/jacobian"),
    "operational_space": ("POST", "/v1/robots/{robot_id}/operational-space"),
    "inertias": ("GET", "/v1/robots/{robot_id}/inertias"),
    "inverse_dynamics_derivatives": ("POST", "/v1/robots/{robot_id}/inverse-dynamics-derivatives"),
    "forward_dynamics_derivatives": ("POST", "/v1/robots/{robot_id}/forward-dynamics-derivatives"),
    "centroidal": ("POST", "/v1/robots/{robot_id}/centroidal"),
    "simulate": ("POST", "/v1/robots/{robot_id}/simulate"),
    "reduce": ("POST", "/v1/robots/{robot_id}/reduce"),
    # contacts (see the block "contacts" below)
    "contact_dynamics": ("POST", "/v1/robots/{robot_id}/contact-dynamics"),
    "contact_inverse_dynamics": ("POST", "/v1/robots/{robot_id}/contact-inverse-dynamics"),
    "impulse_dynamics": ("POST", "/v1/robots/{robot_id}/impulse-dynamics"),
}
"""Client method → (HTTP method, path template) of the server route it calls."""

METHODS: tuple[str, ...] = tuple(ROUTES)

BINARY_FROM = 4096
"""Requests with this many input numbers or more are sent, and answered, in the binary form
(a safetensors file of raw float64 instead of JSON text: see docs/binary-format.md), unless
the client says otherwise (`Client(binary=...)`)."""
MAX_BINARY_ANSWER = 1 << 32  # bytes; a larger Content-Length is not preallocated
Body = bytes | list[bytes | memoryview]  # a request body: whole, or in parts


@dataclass(frozen=True)
class Call(Generic[T]):
    """One request to send, and how to read its answer: `read(status, decoded JSON body)`."""

    method: str
    path: str
    read: Callable[[int, Any], T]
    json: Any = None
    accept: frozenset[int] = frozenset()  # statuses handed to `read` (body None), not raised
    arrays: Mapping[str, np.ndarray] | None = None  # joint-space inputs (JSON or binary form)
    idempotent: bool = True  # may be sent again after a failure that may follow its sending
    rows: int | None = None  # states of a batch
    split: Callable[[int, int], Call[T]] | None = None  # the same call for states [i, j)

    def binary(self, use_binary: bool | None) -> bool:
        """Whether the joint-space inputs go in the binary form (see `body`)."""
        if self.arrays is None or use_binary is False or not all(
                isinstance(a, np.ndarray) for a in self.arrays.values()):
            return False  # inputs keyed by joint name are JSON objects
        return bool(use_binary) or sum(a.size for a in self.arrays.values()) >= BINARY_FROM

    def json_body(self, fill: str | None = None) -> dict[str, Any]:
        """The JSON object of the request (inputs as nested lists, then the other fields);
        with `fill` when an input is keyed by joint name."""
        body = {**to_json(self.arrays or {}), **(self.json or {})}
        if fill is not None and self.arrays is not None and not all(
                isinstance(a, np.ndarray) for a in self.arrays.values()):
            body.setdefault("fill", fill)
        return body

    def body(self, use_binary: bool | None, fill: str | None = None
             ) -> tuple[Body | None, str | None]:
        """The body and its media type: bytes, or for the binary form a list of parts
        (`binary.encode_parts`). Joint-space inputs go in the binary form when `use_binary` is
        True, or when it is None and they hold `BINARY_FROM` numbers or more. `fill`: sent
        with inputs keyed by joint name (how the server fills the joints they leave out)."""
        if self.arrays is not None:
            if self.binary(use_binary):
                return binary.encode_parts(self.arrays, self.json), binary.MEDIA_TYPE
            return encode(self.json_body(fill)), "application/json"
        if self.json is not None:
            return encode(self.json), "application/json"
        return None, None


def _call(name: str, read: Callable[[int, Any], T], robot_id: str | None = None,
          body: Any = None, accept: frozenset[int] = frozenset(),
          arrays: Mapping[str, np.ndarray] | None = None, idempotent: bool = True) -> Call[T]:
    method, template = ROUTES[name]
    path = template
    if robot_id is not None:
        if not isinstance(robot_id, str):
            raise TypeError(f"robot_id must be a str, not {type(robot_id).__name__}")
        if not robot_id:
            raise InputError("robot_id is empty; robots() lists the valid ids")
        path = template.format(robot_id=quote(robot_id, safe=""))
    return Call(method, path, read, body, accept, arrays, idempotent)


def binary_length(response: httpx.Response) -> int | None:
    """The byte length of a successful binary answer sent as is (Content-Length, no content
    coding): such an answer is read into one preallocated buffer (`Receiver`) rather
    than through httpx's chunk list. None for every other answer."""
    headers = response.headers
    if (200 <= response.status_code <= 299
            and headers.get("content-type", "").startswith(binary.MEDIA_TYPE)
            and headers.get("content-encoding", "identity") == "identity"):
        length = headers.get("content-length", "")
        if length.isdigit() and 0 < int(length) <= MAX_BINARY_ANSWER:
            return int(length)
    return None


class Receiver:
    """Collects a body of known length, chunk by chunk, into one preallocated bytearray.

    A large answer (23 MB for 2,000 Talos mass matrices) read by httpx as a list of 64 kB
    chunks and then joined was copied twice more; written straight into its final buffer it is
    copied once, and `binary.decode` makes its arrays views of that buffer."""

    def __init__(self, response: httpx.Response, length: int) -> None:
        self._status = response.status_code
        self.content = bytearray(length)
        self._view = memoryview(self.content)
        self._filled = 0

    def add(self, chunk: bytes) -> None:
        end = self._filled + len(chunk)
        if end > len(self.content):
            raise ResponseFormatError(f"the answer is longer than its Content-Length "
                                      f"{len(self.content)}", status=self._status)
        self._view[self._filled:end] = chunk
        self._filled = end

    def finish(self) -> bytearray:
        if self._filled != len(self.content):
            raise ResponseFormatError(f"the answer ended after {self._filled} of its "
                                      f"{len(self.content)} bytes", status=self._status)
        self._view.release()
        return self.content


def read_response(call: Call[T], response: httpx.Response,
                  received: bytearray | None = None) -> T:
    """The result of `call` from its answer; an `APIError` subclass for an error status.
    `received` is the body already read into a buffer (see `binary_length`), if it was."""
    status = response.status_code
    if status in call.accept:
        return call.read(status, None)
    if not 200 <= status <= 299:
        raise api_error(response)
    body: Any = None
    if received is not None or response.content:
        is_binary = response.headers.get("content-type", "").startswith(binary.MEDIA_TYPE)
        try:
            if received is not None:
                body = binary.decode(received)
            else:
                body = binary.decode(response.content) if is_binary else response.json()
        except ValueError:
            form = "in the binary form it claims" if is_binary else "JSON"
            start = (bytes(received[:1000]).decode("utf-8", "replace") if received is not None
                     else response.text[:1000])
            raise ResponseFormatError(f"{call.method} {call.path} answered {status} with a body "
                                      f"that is not {form}", status=status,
                                      body=start) from None
    try:
        return call.read(status, body)
    except (KeyError, ValueError, TypeError, IndexError) as exc:
        raise ResponseFormatError(f"{call.method} {call.path} answered {status} with an "
                                  f"unexpected body: {exc!s}", status=status, body=body) from exc


def api_error(response: httpx.Response) -> APIError:
    """The exception for an error answer (problem+json, or any other body)."""
    status = response.status_code
    body: Any
    try:
        body = response.json()
    except ValueError:
        body = response.text[:1000]
    problem = body if isinstance(body, dict) else {}
    code = problem.get("code") if isinstance(problem.get("code"), str) else None
    title = str(problem.get("title") or response.reason_phrase or f"HTTP {status}")
    detail = str(problem.get("detail") or (body if isinstance(body, str) and body else title))
    retry_after: float | None
    try:
        retry_after = float(response.headers["retry-after"])
    except (KeyError, ValueError):
        retry_after = None
    return error_class(status, code)(status, code, title, detail, body, retry_after)


def encode(body: Any) -> bytes:
    """The JSON bytes of a request body (inputs were checked finite before)."""
    return json.dumps(body, allow_nan=False, separators=(",", ":")).encode()


# -- operations ---------------------------------------------------------------------------


def health() -> Call[dict[str, Any]]:
    """Liveness: the server's `/health/live` answer, `{"status": "ok"}`."""
    return _call("health", lambda status, body: dict(body))


def ready() -> Call[bool]:
    """Readiness: True once the server has loaded its catalog and can compute, False before."""
    return _call("ready", lambda status, body: status != 503, accept=frozenset({503}))


# -- robots -------------------------------------------------------------------------------


def robots() -> Call[RobotList]:
    """Every robot the server serves, catalog and uploads: a `RobotList` of `RobotSummary`
    (with `unavailable`: catalog robots the server could not load, and why)."""
    return _call("robots", lambda status, body: RobotList.from_json(body))


def robot(robot_id: str) -> Call[RobotInfo]:
    """The `RobotInfo` of one robot: sizes nq and nv, joint layout and limits, frames,
    gravity, total mass, reference configurations and physical findings.
    Raises `RobotNotFoundError` for an unknown id."""
    return _call("robot", lambda status, body: RobotInfo.from_json(body), robot_id)


def _description(value: str | bytes | os.PathLike[str], what: str) -> str:
    """Description text from a str, UTF-8 bytes or a path to a file."""
    if isinstance(value, os.PathLike):
        with open(value, encoding="utf-8") as f:
            return f.read()
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if not isinstance(value, str):
        raise TypeError(f"{what} must be the {what.upper()} text or a path, "
                        f"not {type(value).__name__}")
    return value


def _locked_joints(locked: Mapping[str, ArrayLike]) -> dict[str, Any]:
    """Locked joint positions as JSON: joint name → a number or a list of numbers (finite)."""
    if not isinstance(locked, Mapping) or not locked:
        raise InputError("locked_joints must be a non-empty mapping of joint name to position")
    out: dict[str, Any] = {}
    for name, value in locked.items():
        if not isinstance(name, str):
            raise InputError(f"locked_joints keys must be joint names (str), not "
                             f"{type(name).__name__}")
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (ValueError, TypeError):
            raise InputError(f"locked_joints['{name}'] must be a number or a list of numbers"
                             ) from None
        if arr.ndim > 1 or arr.size == 0:
            raise InputError(f"locked_joints['{name}'] must be a number or a non-empty 1-D "
                             "list of numbers")
        if not np.all(np.isfinite(arr)):
            raise InputError(f"locked_joints['{name}'] must be finite")
        out[name] = float(arr) if arr.ndim == 0 else arr.tolist()
    return out


def upload(source: Source | None = None, *, urdf: Source | None = None,
           mjcf: Source | None = None, xacro: Source | None = None,
           xacro_args: Mapping[str, str] | None = None,
           assets: Mapping[str, AssetValue] | None = None, collect_assets: bool = True,
           root_joint: RootJoint = "fixed", name: str | None = None,
           gravity: ArrayLike | None = None, inertia_check: InertiaCheck | None = None,
           locked_joints: Mapping[str, ArrayLike] | None = None) -> Call[RobotInfo]:
    """Store a model on the server and return its `RobotInfo` (`created` tells whether it is
    new). The id is derived from the content, options and assets, so the same upload gives the
    same id.

    `source` is the description: its text (str or UTF-8 bytes; URDF, MJCF or xacro, told apart
    by its root element), a path to its file, or a directory holding it. From a path, the files
    it references (meshes, included MJCF or xacro files, YAML) are collected and sent as
    assets (see `robodyn.uploads`; `collect_assets=False` sends none); `assets` (key → bytes,
    text or a path) adds or replaces some. `urdf=`, `mjcf=` or `xacro=` name the format
    instead of `source`. `xacro_args` sets a xacro's arguments (strings).

    `root_joint` is "fixed", "free-flyer" or "planar" (an MJCF whose top body has a free joint
    is free-flying by itself); `gravity` is 3 numbers in m/s² (default: an MJCF's own
    `<option gravity>`, else [0, 0, -9.81]); `inertia_check` "reject" (default) or "warn" for
    implausible inertias. `locked_joints` (joint name → position, see `reduce`) stores only the
    reduced model. Raises `InvalidModelError` for a description that is not a usable model."""
    body = upload_body(source, urdf=urdf, mjcf=mjcf, xacro=xacro, assets=assets,
                       collect_assets=collect_assets)
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
    return _call("upload", lambda status, data: RobotInfo.from_json(data, created=status == 201),
                 body=body)


def delete(robot_id: str) -> Call[None]:
    """Delete an uploaded model. Raises `CatalogRobotError` for a catalog robot and
    `RobotNotFoundError` for an unknown id."""
    return _call("delete", lambda status, body: None, robot_id, idempotent=False)


# -- dynamics -----------------------------------------------------------------------------


def _dynamics(name: str, robot_id: str, outputs: Mapping[str, int], *,
              options: Mapping[str, Any] | None = None, result: Callable[..., Any] | None = None,
              square: bool = True, **inputs: ArrayLike) -> Call[Any]:
    """A dynamics call: joint-space `inputs` (arrays, or objects keyed by joint name), extra
    body fields `options`, answers `outputs` (key → dimensions per state) read as arrays and
    returned alone, as a tuple, or as `result(*arrays)`."""
    arrays, batched = joint_states(**inputs)
    rows = batch_rows(arrays, batched)

    def read(status: int, body: Any) -> Any:
        out = tuple(answer_array(body, key, ndim, batched, rows, square)
                    for key, ndim in outputs.items())
        if result is not None:
            return result(*out)
        return out[0] if len(out) == 1 else out

    call = _call(name, read, robot_id, body=dict(options) if options else None, arrays=arrays)
    if _splittable(arrays, rows, options):
        def split(i: int, j: int) -> Call[Any]:
            return _dynamics(name, robot_id, outputs, options=options, result=result,
                             square=square, **{k: a[i:j] for k, a in arrays.items()})
        return replace(call, rows=rows, split=split)
    return call


def _splittable(arrays: Mapping[str, Any], rows: int | None,
                options: Mapping[str, Any] | None) -> bool:
    """Whether a call can be sent in chunks of states: a batch of arrays whose options do not
    depend on the state (per-state external wrenches do)."""
    return (rows is not None and all(isinstance(a, np.ndarray) for a in arrays.values())
            and not (options or {}).get("external_forces"))


def batch_chunks(call: Call[T], chunk: int = progress.CHUNK_STATES) -> progress.Plan[T]:
    """`call` as consecutive calls of at most `chunk` states (see `robodyn.progress.Plan`)."""
    assert call.split is not None and call.rows is not None
    parts: list[T] = []
    for i in range(0, call.rows, chunk):
        j = min(i + chunk, call.rows)
        parts.append((yield (call.split(i, j), j)))
    return outputs.join(parts)


def mass_matrix(robot_id: str, q: ArrayLike) -> Call[np.ndarray]:
    """M(q), the joint-space inertia matrix (CRBA): symmetric positive definite, kg·m² (kg on
    prismatic rows), shape (nv, nv), or (N, nv, nv) for q of shape (N, nq).
    The kinetic energy is ½ vᵀ M v."""
    return _dynamics("mass_matrix", robot_id, {"mass_matrix": 2}, q=q)


def gravity(robot_id: str, q: ArrayLike) -> Call[np.ndarray]:
    """g(q), the generalized gravity torques (the gradient of the potential energy), N·m or N,
    shape (nv,), or (N, nv) for q of shape (N, nq)."""
    return _dynamics("gravity", robot_id, {"gravity": 1}, q=q)


def coriolis(robot_id: str, q: ArrayLike, v: ArrayLike) -> Call[tuple[np.ndarray, np.ndarray]]:
    """(C, C v): the Coriolis/centrifugal matrix C(q, v) with Ṁ = C + Cᵀ, N·m·s, shape
    (nv, nv), and the forces C(q, v) v, N·m or N, shape (nv,); with a batch axis N for
    inputs of shape (N, nq) and (N, nv)."""
    return _dynamics("coriolis", robot_id, {"coriolis_matrix": 2, "coriolis_forces": 1},
                     q=q, v=v)


def nonlinear_effects(robot_id: str, q: ArrayLike, v: ArrayLike) -> Call[np.ndarray]:
    """h(q, v) = C(q, v) v + g(q) (gravity included, as in Pinocchio), N·m or N, shape (nv,),
    or (N, nv) for a batch."""
    return _dynamics("nonlinear_effects", robot_id, {"nonlinear_effects": 1}, q=q, v=v)


def inverse_dynamics(robot_id: str, q: ArrayLike, v: ArrayLike, a: ArrayLike, *,
                     external_forces: Sequence[Mapping[str, Any]] | None = None
                     ) -> Call[np.ndarray]:
    """τ = M(q) a + C(q, v) v + g(q) (RNEA): the generalized forces, N·m or N, that give the
    accelerations a (rad/s² or m/s²); shape (nv,), or (N, nv) for a batch.
    `external_forces`: wrenches the environment applies, `[{"frame": "tool0", "wrench":
    [fx, fy, fz, tx, ty, tz], "reference_frame": "local_world_aligned"}]` (N, N·m; a wrench
    may be (N, 6), one per state); then τ = M a + C v + g − Σ Jᵀ w."""
    return _dynamics("inverse_dynamics", robot_id, {"tau": 1}, q=q, v=v, a=a,
                     options=request_options.external_forces(external_forces))


def forward_dynamics(robot_id: str, q: ArrayLike, v: ArrayLike, tau: ArrayLike, *,
                     external_forces: Sequence[Mapping[str, Any]] | None = None
                     ) -> Call[np.ndarray]:
    """a = M(q)⁻¹ (τ − C(q, v) v − g(q)) (ABA): the accelerations, rad/s² or m/s², that the
    generalized forces τ (N·m or N) produce; shape (nv,), or (N, nv) for a batch.
    `external_forces` as for `inverse_dynamics`: then a = M⁻¹ (τ − C v − g + Σ Jᵀ w)."""
    return _dynamics("forward_dynamics", robot_id, {"a": 1}, q=q, v=v, tau=tau,
                     options=request_options.external_forces(external_forces))


def inverse_dynamics_derivatives(robot_id: str, q: ArrayLike, v: ArrayLike, a: ArrayLike
                                 ) -> Call[InverseDynamicsDerivatives]:
    """(∂τ/∂q, ∂τ/∂v, ∂τ/∂a = M(q)) of inverse dynamics (analytical RNEA derivatives), each
    of shape (nv, nv), or (N, nv, nv) for a batch. ∂/∂q is on the tangent space: nv columns,
    along q ⊕ δq (for a free-flyer, δq's first 6 entries are a displacement in the base frame)."""
    return _dynamics("inverse_dynamics_derivatives", robot_id,
                     {"dtau_dq": 2, "dtau_dv": 2, "dtau_da": 2},
                     result=InverseDynamicsDerivatives, q=q, v=v, a=a)


def forward_dynamics_derivatives(robot_id: str, q: ArrayLike, v: ArrayLike, tau: ArrayLike
                                 ) -> Call[ForwardDynamicsDerivatives]:
    """(∂a/∂q, ∂a/∂v, ∂a/∂τ = M(q)⁻¹) of forward dynamics (analytical ABA derivatives), each
    of shape (nv, nv), or (N, nv, nv) for a batch; ∂/∂q on the tangent space (nv columns)."""
    return _dynamics("forward_dynamics_derivatives", robot_id,
                     {"da_dq": 2, "da_dv": 2, "da_dtau": 2},
                     result=ForwardDynamicsDerivatives, q=q, v=v, tau=tau)


def centroidal(robot_id: str, q: ArrayLike, v: ArrayLike) -> Call[Centroidal]:
    """(momentum, momentum_matrix, center_of_mass): the centroidal momentum h = A(q) v, shape
    (6,), linear (kg·m/s) then angular (kg·m²/s) about the centre of mass in world-aligned axes;
    the centroidal momentum matrix A(q), shape (6, nv); the centre of mass, shape (3,), m.
    A leading axis N for a batch."""
    return _dynamics("centroidal", robot_id,
                     {"momentum": 1, "momentum_matrix": 2, "center_of_mass": 1},
                     result=Centroidal, square=False, q=q, v=v)


def simulate(robot_id: str, q: ArrayLike, v: ArrayLike, *, dt: float, steps: int,
             tau: ArrayLike | Mapping[str, Any] | None = None,
             controller: Mapping[str, Any] | None = None, integrator: Integrator | None = None,
             contacts: ContactsLike | None = None, damping: float = 0.0
             ) -> Call[Trajectory | ContactTrajectory]:
    """Integrate forward dynamics from (q, v) for `steps` steps of `dt` seconds: a
    `Trajectory` (t, q, v, mechanical_energy) of steps + 1 samples, q of shape (steps + 1, nq),
    v (steps + 1, nv); with a leading axis N for initial states of shape (N, nq), (N, nv).
    `tau`: nv numbers (constant) or (steps, nv) (τ_k during step k); or `controller`:
    `{"type": "pd", "kp": ..., "kd": ..., "q_target": ..., "gravity_compensation": False}`
    (gains: a number or nv numbers); neither means τ = 0. `integrator`: "semi-implicit-euler"
    (default) or "rk4". `contacts` (a fixed contact set, e.g. `RobotInfo.contact_frames`)
    gives a `ContactTrajectory` (with `constraint_drift`, m): the contacts hold their frames
    where they start, and a PD controller acts on the actuated joints only. `progress` (the
    client's by default): a callable `(done, total)` or True (a tqdm bar) runs more than
    `progress.CHUNK_STEPS` steps in chunks, each from the last state of the one before,
    reporting the steps done after each; the trajectory is bit for bit that of one request.
    A rollout with `contacts` is never chunked."""
    options = request_options.simulation(dt, steps, tau, controller, integrator)
    if contacts is not None:  # contacts (issue 19)
        return _simulate_with_contacts(robot_id, q, v, options, contacts, damping)
    call = _dynamics("simulate", robot_id, {"t": 1, "q": 2, "v": 2, "mechanical_energy": 1},
                     result=Trajectory, square=False, options=options, q=q, v=v)
    # Always JSON: a torque schedule is a body field, too big for a binary header.
    return replace(call, json=call.json_body(), arrays=None)


def simulate_chunks(robot_id: str, q: ArrayLike, v: ArrayLike, *, dt: float, steps: int,
                    tau: ArrayLike | Mapping[str, Any] | None = None,
                    controller: Mapping[str, Any] | None = None,
                    integrator: Integrator | None = None, chunk: int = progress.CHUNK_STEPS
                    ) -> progress.Plan[Trajectory]:
    """`simulate` as consecutive simulations of at most `chunk` steps, each starting from the
    last state of the one before (see `robodyn.progress.Plan`): the same trajectory, bit for
    bit, as one request (t is dt × step index in both)."""
    simulate(robot_id, q, v, dt=dt, steps=steps, tau=tau, controller=controller,
             integrator=integrator)  # checks every argument before the first chunk
    schedule = None
    if tau is not None and not isinstance(tau, Mapping):
        torques = joint_input("tau", tau)
        if isinstance(torques, np.ndarray) and torques.ndim == 2:
            schedule = torques  # (steps, nv): τ_k during step k
    parts: list[Trajectory] = []
    done = 0
    while done < steps:
        n = min(chunk, steps - done)
        part_tau = schedule[done:done + n] if schedule is not None else tau
        part: Trajectory = yield (simulate(robot_id, q, v, dt=dt, steps=n, tau=part_tau,
                                           controller=controller, integrator=integrator),
                                  done + n)
        parts.append(part if not parts else Trajectory(*(x[..., 1:, :] if x.ndim > part.t.ndim
                                                          else x[..., 1:] for x in part)))
        q, v = part.q[..., -1, :], part.v[..., -1, :]
        done += n
    joined = Trajectory(*(np.concatenate(xs, axis=-2 if xs[0].ndim > parts[0].t.ndim else -1)
                          for xs in zip(*parts, strict=True)))
    t = np.broadcast_to(dt * np.arange(steps + 1), joined.t.shape).copy()
    return joined._replace(t=t)


def reduce(robot_id: str, locked_joints: Mapping[str, ArrayLike], *, name: str | None = None
           ) -> Call[RobotInfo]:
    """Store the reduced model of any robot (catalog or upload) with `locked_joints` locked and
    return its `RobotInfo` (a new durable id; `created` tells whether it is new, and
    `raw["reduced_from"]` names the base robot and each locked joint's q entries).
    `locked_joints` maps joint names to positions: a number (rad or m) for revolute and
    prismatic joints, an angle or [cos θ, sin θ] for continuous ones, [x, y, z, qx, qy, qz, qw]
    for a free-flyer, [x, y, θ] or [x, y, cos θ, sin θ] for a planar joint, [qx, qy, qz, qw]
    for a spherical one ([qw, qx, qy, qz], MuJoCo's qpos order, for a model uploaded as MJCF).
    Raises `ValidationError` for an unknown joint (all listed) or a value
    of the wrong size, `InvalidConfigurationError` for a value outside the joint's limits, and
    `InvalidModelError` when every moving joint would be locked."""
    body: dict[str, Any] = {"locked_joints": _locked_joints(locked_joints)}
    if name is not None:
        body["name"] = name
    return _call("reduce", lambda status, data: RobotInfo.from_json(data, created=status == 201),
                 robot_id, body)


# -- contacts -----------------------------------------------------------------------------


def _contact_options(contacts: ContactsLike, damping: float) -> dict[str, Any]:
    options: dict[str, Any] = {"contacts": contacts_body(contacts)}
    if nonnegative("damping", damping):
        options["damping"] = float(damping)
    return options


def contact_dynamics(robot_id: str, q: ArrayLike, v: ArrayLike, tau: ArrayLike,
                     contacts: ContactsLike, *, damping: float = 0.0
                     ) -> Call[ContactDynamics]:
    """`ContactDynamics` (a, contact_forces): constrained forward dynamics with rigid
    contacts, M a + h = τ + Jcᵀ λ with Jc a + γ = 0. `contacts`: a list of
    `{"frame": name, "type": "point" | "6d"}` (a robot's feet: `RobotInfo.contact_frames`).
    `a` has shape (nv,) and `contact_forces` (m,) — N (and N·m for 6d contacts), at each
    frame's origin with the world's axes, in the order of `contacts`; a leading axis N for a
    batch. Raises `UnknownFrameError` for an unknown frame and `SingularConfigurationError`
    for a rank-deficient contact set unless `damping` μ > 0 (the regularized solution)."""
    return _quantity("contact_dynamics", robot_id, ContactDynamics.from_json,
                     _contact_options(contacts, damping), q=q, v=v, tau=tau)


def contact_inverse_dynamics(robot_id: str, q: ArrayLike, v: ArrayLike, a: ArrayLike,
                             contacts: ContactsLike, *, damping: float = 0.0
                             ) -> Call[ContactInverseDynamics]:
    """`ContactInverseDynamics` (tau, contact_forces, residual): the joint torques τ (zero on
    a floating base's root rows) and the minimum-norm contact forces λ with
    M a + h = τ + Jcᵀ λ; `residual` is the 2-norm of the root wrench no contact force can
    produce (0 when the contacts can hold the motion). The shapes: τ (nv,), λ (m,), laid out as
    in `contact_dynamics`, residual a float; a leading axis N for a batch. No friction cone:
    λ may pull. For a fixed-base robot λ = 0 and τ = M a + h. Errors as `contact_dynamics`."""
    return _quantity("contact_inverse_dynamics", robot_id, ContactInverseDynamics.from_json,
                     _contact_options(contacts, damping), q=q, v=v, a=a)


def impulse_dynamics(robot_id: str, q: ArrayLike, v: ArrayLike, contacts: ContactsLike, *,
                     restitution: float = 0.0, damping: float = 0.0
                     ) -> Call[ImpulseDynamics]:
    """`ImpulseDynamics` (v, contact_impulses): the velocity just after a rigid impact at
    `contacts`, M (v⁺ − v⁻) = Jcᵀ Λ with Jc v⁺ = −e Jc v⁻ (`restitution` e in [0, 1]), and
    the impulses Λ in N·s (N·m·s), laid out like contact forces. The shapes: v (nv,), Λ (m,); a
    leading axis N for a batch. Errors as `contact_dynamics`."""
    options = _contact_options(contacts, damping)
    options["restitution"] = nonnegative("restitution", restitution, upper=1.0)
    return _quantity("impulse_dynamics", robot_id, ImpulseDynamics.from_json, options,
                     q=q, v=v)


def _simulate_with_contacts(robot_id: str, q: ArrayLike, v: ArrayLike,
                            options: dict[str, Any], contacts: ContactsLike, damping: float
                            ) -> Call[Any]:
    options = {**options, **_contact_options(contacts, damping)}
    call = _dynamics("simulate", robot_id, {"t": 1, "q": 2, "v": 2, "mechanical_energy": 1,
                                            "constraint_drift": 1},
                     result=ContactTrajectory, square=False, options=options, q=q, v=v)
    return replace(call, json=call.json_body(), arrays=None)


def share_docs(cls: type) -> type:
    """Give a client class's methods the docstrings of the functions here (class decorator)."""
    for name in METHODS:
        getattr(cls, name).__doc__ = globals()[name].__doc__
    return cls


# -- beyond the equation of motion --------------------------------------------------------

def _choice(name: str, value: Any, allowed: tuple[str, ...]) -> str:
    if not isinstance(value, str) or value not in allowed:
        raise InputError(f"{name} must be one of {', '.join(map(repr, allowed))}, "
                         f"not {value!r}")
    return value


def _frame(frame: Any) -> str:
    if not isinstance(frame, str):
        raise TypeError(f"frame must be a str (a name from robot(id).frame_names), not "
                        f"{type(frame).__name__}")
    if not frame:
        raise InputError("frame is empty; robot(id).frame_names lists the valid names")
    return frame


def _quantity(name: str, robot_id: str, read: Callable[[Any, bool, int | None], T],
              options: Mapping[str, Any], **inputs: ArrayLike | None) -> Call[T]:
    """A dynamics call with joint-space `inputs` (None: not sent) and other `options`."""
    arrays, batched = joint_states(**{k: x for k, x in inputs.items() if x is not None})
    rows = batch_rows(arrays, batched)
    call = _call(name, lambda status, body: read(body, batched, rows), robot_id,
                 body=dict(options) or None, arrays=arrays)
    if _splittable(arrays, rows, options):
        def split(i: int, j: int) -> Call[T]:
            return _quantity(name, robot_id, read, options,
                             **{k: a[i:j] for k, a in arrays.items()})
        return replace(call, rows=rows, split=split)
    return call


def mass_matrix_inverse(robot_id: str, q: ArrayLike) -> Call[np.ndarray]:
    """M(q)⁻¹, the inverse joint-space inertia matrix (Pinocchio's computeMinverse, no
    numerical inversion): symmetric positive definite, 1/(kg·m²) (1/kg on prismatic rows),
    shape (nv, nv), or (N, nv, nv) for q of shape (N, nq)."""
    return _dynamics("mass_matrix_inverse", robot_id, {"mass_matrix_inverse": 2}, q=q)


def energy(robot_id: str, q: ArrayLike, v: ArrayLike) -> Call[Energy]:
    """`Energy` with `kinetic_energy` T = ½ vᵀ M v, `potential_energy` U (zero at the world
    origin, g(q) = ∂U/∂q) and `mechanical_energy` T + U, in J: floats for one state, arrays of
    shape (N,) for a batch. Along any motion d(T + U)/dt = vᵀ τ (τ the applied torques)."""
    return _quantity("energy", robot_id, Energy.from_json, {}, q=q, v=v)


def center_of_mass(robot_id: str, q: ArrayLike, v: ArrayLike | None = None
                   ) -> Call[CenterOfMass]:
    """`CenterOfMass` of the whole robot in the world frame: `position` shape (3,) in m,
    `jacobian` ∂c/∂q shape (3, nv), and with v `velocity` shape (3,) in m/s (else None);
    a leading axis N for a batch."""
    return _quantity("center_of_mass", robot_id, CenterOfMass.from_json, {}, q=q, v=v)


def jacobian(robot_id: str, q: ArrayLike, frame: str, *,
             reference_frame: ReferenceFrame = "local_world_aligned",
             v: ArrayLike | None = None) -> Call[FrameJacobian]:
    """`FrameJacobian` of the frame named `frame` (a link, joint or fixed frame:
    `robot(id).frame_names`): `jacobian` J, shape (6, nv), rows [vx, vy, vz, ωx, ωy, ωz] in
    `reference_frame` ("local_world_aligned", "local" or "world"), so the frame's velocity is
    J v; with v also `jacobian_time_variation` J̇, shape (6, nv) (acceleration J a + J̇ v).
    A leading axis N for a batch. Raises `UnknownFrameError` for a name the robot lacks."""
    options = {"frame": _frame(frame),
               "reference_frame": _choice("reference_frame", reference_frame,
                                          REFERENCE_FRAMES)}
    return _quantity("jacobian", robot_id, FrameJacobian.from_json, options, q=q, v=v)


def operational_space(robot_id: str, q: ArrayLike, frame: str, *, v: ArrayLike | None = None,
                      reference_frame: ReferenceFrame = "local_world_aligned",
                      task: Task = "full", damping: float = 0.0) -> Call[OperationalSpace]:
    """`OperationalSpace` of `frame` (Khatib): `inertia` Λ = (J M⁻¹ Jᵀ)⁻¹ shape (k, k),
    `jacobian` J shape (k, nv), `dynamically_consistent_inverse` J̄ = M⁻¹ Jᵀ Λ shape (nv, k),
    `gravity` p = J̄ᵀ g shape (k,) and with v `coriolis` μ = J̄ᵀ C v − Λ J̇ v shape (k,);
    k = 6 for `task` "full" ([linear; angular]), 3 for "linear" or "angular". SI units: kg and
    kg·m², N and N·m. A leading axis N for a batch. At a singular configuration (smallest
    singular value of J M⁻¹ Jᵀ at most 1e-8 times its largest) raises
    `SingularConfigurationError` unless `damping` λ > 0, which uses (J M⁻¹ Jᵀ + λ² I)⁻¹."""
    if isinstance(damping, bool) or not isinstance(damping, numbers.Real):
        raise InputError(f"damping must be a number, not {type(damping).__name__}")
    if not np.isfinite(damping) or damping < 0:
        raise InputError(f"damping must be a finite number ≥ 0, not {damping!r}")
    options = {"frame": _frame(frame),
               "reference_frame": _choice("reference_frame", reference_frame,
                                          REFERENCE_FRAMES),
               "task": _choice("task", task, TASKS), "damping": float(damping)}
    return _quantity("operational_space", robot_id, OperationalSpace.from_json, options,
                     q=q, v=v)


def inertias(robot_id: str) -> Call[Inertias]:
    """`Inertias` of every body (one per joint): mass (kg), centre of mass (shape (3,), m) and
    inertia at it and at the joint (shape (3, 3), kg·m²), principal moments and axes, all in
    the joint's frame; and `total_mass`. Raises `RobotNotFoundError` for an unknown id."""
    return _call("inertias", lambda status, body: Inertias.from_json(body), robot_id)
