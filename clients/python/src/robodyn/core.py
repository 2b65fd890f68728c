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
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Generic, TypeVar
from urllib.parse import quote

import httpx
import numpy as np

from robodyn.arrays import ArrayLike, answer_array, gravity_vector, joint_states, to_json
from robodyn.errors import APIError, InputError, ResponseFormatError, error_class
from robodyn.models import RobotInfo, RobotList

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
    "reduce": ("POST", "/v1/robots/{robot_id}/reduce"),
}
"""Client method → (HTTP method, path template) of the server route it calls."""

METHODS: tuple[str, ...] = tuple(ROUTES)


@dataclass(frozen=True)
class Call(Generic[T]):
    """One request to send, and how to read its answer: `read(status, decoded JSON body)`."""

    method: str
    path: str
    read: Callable[[int, Any], T]
    json: Any = None
    accept: frozenset[int] = frozenset()  # statuses handed to `read` (body None), not raised


def _call(name: str, read: Callable[[int, Any], T], robot_id: str | None = None,
          body: Any = None, accept: frozenset[int] = frozenset()) -> Call[T]:
    method, template = ROUTES[name]
    path = template
    if robot_id is not None:
        if not isinstance(robot_id, str):
            raise TypeError(f"robot_id must be a str, not {type(robot_id).__name__}")
        if not robot_id:
            raise InputError("robot_id is empty; robots() lists the valid ids")
        path = template.format(robot_id=quote(robot_id, safe=""))
    return Call(method, path, read, body, accept)


def read_response(call: Call[T], response: httpx.Response) -> T:
    """The result of `call` from its answer; an `APIError` subclass for an error status."""
    status = response.status_code
    if status in call.accept:
        return call.read(status, None)
    if not 200 <= status <= 299:
        raise api_error(response)
    body: Any = None
    if response.content:
        try:
            body = response.json()
        except ValueError:
            raise ResponseFormatError(f"{call.method} {call.path} answered {status} with a body "
                                      "that is not JSON", status=status,
                                      body=response.text[:1000]) from None
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


def upload(urdf: str | bytes | os.PathLike[str] | None = None, *,
           mjcf: str | bytes | os.PathLike[str] | None = None, root_joint: str = "fixed",
           name: str | None = None, gravity: ArrayLike | None = None,
           inertia_check: str | None = None,
           locked_joints: Mapping[str, ArrayLike] | None = None) -> Call[RobotInfo]:
    """Store a URDF (or, with `mjcf=`, an MJCF) model on the server and return its `RobotInfo`
    (`created` tells whether it is new). The id is derived from the content and options, so the
    same upload gives the same id. `urdf`/`mjcf` is the XML text (str or UTF-8 bytes) or a path
    to a file (give exactly one); `root_joint` is "fixed", "free-flyer" or "planar" (an MJCF
    whose top body has a free joint is free-flying by itself); `gravity` is 3 numbers in m/s²
    (default [0, 0, -9.81]); `inertia_check` "reject" (default) or "warn" for implausible
    inertias. `locked_joints` (joint name → position, see `reduce`) stores only the reduced
    model. Raises `InvalidModelError` for a description that is not a usable model."""
    if (urdf is None) == (mjcf is None):
        raise InputError("give exactly one of urdf and mjcf")
    body: dict[str, Any] = ({"urdf": _description(urdf, "urdf")} if urdf is not None
                            else {"mjcf": _description(mjcf, "mjcf")})  # type: ignore[arg-type]
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
    return _call("delete", lambda status, body: None, robot_id)


# -- dynamics -----------------------------------------------------------------------------


def _dynamics(name: str, robot_id: str, outputs: Mapping[str, int], **inputs: ArrayLike
              ) -> Call[Any]:
    arrays, batched = joint_states(**inputs)
    rows = next(iter(arrays.values())).shape[0] if batched else None

    def read(status: int, body: Any) -> Any:
        out = tuple(answer_array(body, key, ndim, batched, rows) for key, ndim in outputs.items())
        return out[0] if len(out) == 1 else out

    return _call(name, read, robot_id, to_json(arrays))


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


def inverse_dynamics(robot_id: str, q: ArrayLike, v: ArrayLike, a: ArrayLike
                     ) -> Call[np.ndarray]:
    """τ = M(q) a + C(q, v) v + g(q) (RNEA): the generalized forces, N·m or N, that give the
    accelerations a (rad/s² or m/s²); shape (nv,), or (N, nv) for a batch."""
    return _dynamics("inverse_dynamics", robot_id, {"tau": 1}, q=q, v=v, a=a)


def forward_dynamics(robot_id: str, q: ArrayLike, v: ArrayLike, tau: ArrayLike
                     ) -> Call[np.ndarray]:
    """a = M(q)⁻¹ (τ − C(q, v) v − g(q)) (ABA): the accelerations, rad/s² or m/s², that the
    generalized forces τ (N·m or N) produce; shape (nv,), or (N, nv) for a batch."""
    return _dynamics("forward_dynamics", robot_id, {"a": 1}, q=q, v=v, tau=tau)


def reduce(robot_id: str, locked_joints: Mapping[str, ArrayLike], *, name: str | None = None
           ) -> Call[RobotInfo]:
    """Store the reduced model of any robot (catalog or upload) with `locked_joints` locked and
    return its `RobotInfo` (a new durable id; `created` tells whether it is new, and
    `raw["reduced_from"]` names the base robot and each locked joint's q entries).
    `locked_joints` maps joint names to positions: a number (rad or m) for revolute and
    prismatic joints, an angle or [cos θ, sin θ] for continuous ones, [x, y, z, qx, qy, qz, qw]
    for a free-flyer, [x, y, θ] or [x, y, cos θ, sin θ] for a planar joint, [qx, qy, qz, qw]
    for a spherical one. Raises `ValidationError` for an unknown joint (all listed) or a value
    of the wrong size, `InvalidConfigurationError` for a value outside the joint's limits, and
    `InvalidModelError` when every moving joint would be locked."""
    body: dict[str, Any] = {"locked_joints": _locked_joints(locked_joints)}
    if name is not None:
        body["name"] = name
    return _call("reduce", lambda status, data: RobotInfo.from_json(data, created=status == 201),
                 robot_id, body)


def share_docs(cls: type) -> type:
    """Give a client class's methods the docstrings of the functions here (class decorator)."""
    for name in METHODS:
        getattr(cls, name).__doc__ = globals()[name].__doc__
    return cls
