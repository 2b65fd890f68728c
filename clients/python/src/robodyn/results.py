"""Typed results of the quantities beyond the equation of motion: energy, centre of mass,
frame Jacobians, operational space and body inertias (frozen dataclasses), and derivatives,
centroidal momentum and simulated trajectories (named tuples, which also unpack:
`dtau_dq, dtau_dv, M = client.inverse_dynamics_derivatives(...)`).

Arrays are float64 numpy arrays; for a batch of N states every array gains a leading axis N
(scalars per state become arrays of shape (N,)). Optional parts the request did not ask for
(e.g. velocities without v) are None. Units are SI. 6-vectors and the rows of 6-row Jacobians
are [linear; angular]: m/s (or N) first, then rad/s (or N·m). `k` is the number of task rows:
6 for `task="full"`, 3 for "linear" and "angular".
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np

from robodyn.arrays import answer_array


def read(
    body: Mapping[str, Any], key: str, ndim: int, batched: bool, rows: int | None
) -> np.ndarray:
    """Field `key` with `ndim` dimensions per state (any shape: Jacobians are not square)."""
    return answer_array(body, key, ndim, batched, rows, square=False)


def read_optional(
    body: Mapping[str, Any], key: str, ndim: int, batched: bool, rows: int | None
) -> np.ndarray | None:
    return read(body, key, ndim, batched, rows) if body.get(key) is not None else None


@dataclass(frozen=True, eq=False)
class Energy:
    """`kinetic_energy` T = ½ vᵀ M v, `potential_energy` U (zero at the world origin; g(q) =
    ∂U/∂q) and `mechanical_energy` T + U, in J: floats for one state, arrays (N,) for a
    batch."""

    kinetic_energy: float | np.ndarray
    potential_energy: float | np.ndarray
    mechanical_energy: float | np.ndarray

    @classmethod
    def from_json(cls, body: Mapping[str, Any], batched: bool, rows: int | None) -> Energy:
        values = [
            read(body, key, 0, batched, rows)
            for key in ("kinetic_energy", "potential_energy", "mechanical_energy")
        ]
        if not batched:
            return cls(*(float(x) for x in values))
        return cls(*values)


@dataclass(frozen=True, eq=False)
class CenterOfMass:
    """Centre of mass of the whole robot in the world frame: `position` (3,) in m, `jacobian`
    J_c = ∂c/∂q (3, nv), and with v `velocity` ċ = J_c v (3,) in m/s (else None)."""

    position: np.ndarray
    jacobian: np.ndarray
    velocity: np.ndarray | None

    @classmethod
    def from_json(cls, body: Mapping[str, Any], batched: bool, rows: int | None) -> CenterOfMass:
        return cls(
            position=read(body, "position", 1, batched, rows),
            jacobian=read(body, "jacobian", 2, batched, rows),
            velocity=read_optional(body, "velocity", 1, batched, rows),
        )


@dataclass(frozen=True, eq=False)
class FrameJacobian:
    """`jacobian` J (6, nv) of a frame in the requested reference frame, rows [linear;
    angular]: the frame's velocity is J v. With v, `jacobian_time_variation` J̇ (6, nv), so
    that its acceleration is J a + J̇ v (else None)."""

    jacobian: np.ndarray
    jacobian_time_variation: np.ndarray | None

    @classmethod
    def from_json(cls, body: Mapping[str, Any], batched: bool, rows: int | None) -> FrameJacobian:
        return cls(
            jacobian=read(body, "jacobian", 2, batched, rows),
            jacobian_time_variation=read_optional(
                body, "jacobian_time_variation", 2, batched, rows
            ),
        )


@dataclass(frozen=True, eq=False)
class OperationalSpace:
    """Operational-space dynamics of a frame (Khatib): with ẍ = J a + J̇ v and τ = Jᵀ F,
    Λ ẍ + μ + p = F.

    `inertia` Λ = (J M⁻¹ Jᵀ)⁻¹ (k, k), kg / kg·m² (with damping λ: (J M⁻¹ Jᵀ + λ² I)⁻¹);
    `jacobian` J (k, nv); `dynamically_consistent_inverse` J̄ = M⁻¹ Jᵀ Λ (nv, k);
    `gravity` p = J̄ᵀ g (k,), N / N·m; `coriolis` μ = J̄ᵀ C v − Λ J̇ v (k,) with v, else
    None.
    """

    inertia: np.ndarray
    jacobian: np.ndarray
    dynamically_consistent_inverse: np.ndarray
    gravity: np.ndarray
    coriolis: np.ndarray | None

    @classmethod
    def from_json(
        cls, body: Mapping[str, Any], batched: bool, rows: int | None
    ) -> OperationalSpace:
        return cls(
            inertia=read(body, "inertia", 2, batched, rows),
            jacobian=read(body, "jacobian", 2, batched, rows),
            dynamically_consistent_inverse=read(
                body, "dynamically_consistent_inverse", 2, batched, rows
            ),
            gravity=read(body, "gravity", 1, batched, rows),
            coriolis=read_optional(body, "coriolis", 1, batched, rows),
        )


def _matrix(values: Any) -> np.ndarray:
    arr = np.array(values, dtype=np.float64)
    if arr.shape != (3, 3):
        raise ValueError(f"expected a 3×3 matrix, got shape {arr.shape}")
    arr.flags.writeable = False
    return arr


def _vector3(values: Any) -> np.ndarray:
    arr = np.array(values, dtype=np.float64)
    if arr.shape != (3,):
        raise ValueError(f"expected 3 numbers, got shape {arr.shape}")
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True, eq=False)
class BodyInertia:
    """The rigid body moved by `joint` (its link `name` and the `links` fixed to it), all in
    the joint's frame: `mass` (kg), `center_of_mass` (3,) m, `inertia_at_center_of_mass` and
    `inertia_at_joint` (3, 3) kg·m² (parallel-axis theorem), `principal_moments` (3,)
    ascending and `principal_axes` (3, 3), a rotation whose columns are the axes."""

    name: str
    joint: str
    links: tuple[str, ...]
    mass: float
    center_of_mass: np.ndarray
    inertia_at_center_of_mass: np.ndarray
    inertia_at_joint: np.ndarray
    principal_moments: np.ndarray
    principal_axes: np.ndarray
    raw: Mapping[str, Any] = field(repr=False)

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> BodyInertia:
        return cls(
            name=str(data["name"]),
            joint=str(data["joint"]),
            links=tuple(str(x) for x in data.get("links", ())),
            mass=float(data["mass"]),
            center_of_mass=_vector3(data["center_of_mass"]),
            inertia_at_center_of_mass=_matrix(data["inertia_at_center_of_mass"]),
            inertia_at_joint=_matrix(data["inertia_at_joint"]),
            principal_moments=_vector3(data["principal_moments"]),
            principal_axes=_matrix(data["principal_axes"]),
            raw=MappingProxyType(dict(data)),
        )


@dataclass(frozen=True, eq=False)
class Inertias(Sequence[BodyInertia]):
    """The answer of `inertias(id)`: a sequence of `BodyInertia`, one per joint in model order,
    and `total_mass` (kg). `inertias["elbow_joint"]` looks a body up by joint or link name."""

    total_mass: float
    bodies: tuple[BodyInertia, ...]

    def __len__(self) -> int:
        return len(self.bodies)

    def __iter__(self) -> Iterator[BodyInertia]:
        return iter(self.bodies)

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, str):
            for body in self.bodies:
                if key in (body.joint, body.name):
                    return body
            names = ", ".join(b.joint for b in self.bodies)
            raise KeyError(f"no body has the joint or link name {key!r}; joints: {names}")
        return self.bodies[key]

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Inertias:
        return cls(
            total_mass=float(data["total_mass"]),
            bodies=tuple(BodyInertia.from_json(b) for b in data["bodies"]),
        )


class InverseDynamicsDerivatives(NamedTuple):
    """∂τ/∂q, ∂τ/∂v, ∂τ/∂a = M(q), each (nv, nv) (∂/∂q on the tangent space: nv columns)."""

    dtau_dq: np.ndarray
    dtau_dv: np.ndarray
    dtau_da: np.ndarray

    @classmethod
    def from_json(
        cls, body: Mapping[str, Any], batched: bool, rows: int | None
    ) -> InverseDynamicsDerivatives:
        return cls(*(answer_array(body, key, 2, batched, rows) for key in cls._fields))


class ForwardDynamicsDerivatives(NamedTuple):
    """∂a/∂q, ∂a/∂v, ∂a/∂τ = M(q)⁻¹, each (nv, nv) (∂/∂q on the tangent space)."""

    da_dq: np.ndarray
    da_dv: np.ndarray
    da_dtau: np.ndarray

    @classmethod
    def from_json(
        cls, body: Mapping[str, Any], batched: bool, rows: int | None
    ) -> ForwardDynamicsDerivatives:
        return cls(*(answer_array(body, key, 2, batched, rows) for key in cls._fields))


class Centroidal(NamedTuple):
    """Centroidal momentum (6: kg·m/s then kg·m²/s, about the centre of mass, world-aligned),
    the centroidal momentum matrix (6, nv) and the centre of mass (3, m, world frame)."""

    momentum: np.ndarray
    momentum_matrix: np.ndarray
    center_of_mass: np.ndarray

    @classmethod
    def from_json(cls, body: Mapping[str, Any], batched: bool, rows: int | None) -> Centroidal:
        return cls(
            read(body, "momentum", 1, batched, rows),
            read(body, "momentum_matrix", 2, batched, rows),
            read(body, "center_of_mass", 1, batched, rows),
        )


class Trajectory(NamedTuple):
    """A simulated trajectory of steps + 1 samples: times t (s), configurations q
    (steps + 1, nq), velocities v (steps + 1, nv) and the mechanical energy T + U (J); with a
    leading axis N for a batch of initial states."""

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    mechanical_energy: np.ndarray

    @classmethod
    def from_json(cls, body: Mapping[str, Any], batched: bool, rows: int | None) -> Trajectory:
        return cls(*trajectory_arrays(body, cls._fields, batched, rows))


def trajectory_arrays(
    body: Mapping[str, Any], fields: Sequence[str], batched: bool, rows: int | None
) -> list[np.ndarray]:
    """A trajectory's fields: q and v have 2 dimensions per initial state, the others 1."""
    return [read(body, key, 2 if key in ("q", "v") else 1, batched, rows) for key in fields]
