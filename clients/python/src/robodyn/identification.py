"""Answers of the identification routes: a robot's inertial parameters and an identification.

`InertialParameters` is `GET /v1/robots/{id}/inertial-parameters`; `Identification` is
`POST /v1/robots/{id}/identify` (docs/identification.md explains every number).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from robodyn.errors import InputError
from robodyn.models import RobotInfo
from robodyn.payloads import Payload


def _vector(value: Any) -> np.ndarray:
    return np.asarray(value, dtype=float)


def _payload(body: Mapping[str, Any]) -> Payload | dict[str, Any]:
    """The identified payload as a `Payload`; as the server's dict when it is not a physically
    possible one (a least-squares fit may give a negative mass or inertia)."""
    try:
        return Payload(body["frame"], body["mass"], body["center_of_mass"], body["inertia"])
    except (InputError, TypeError, ValueError):
        return dict(body)


@dataclass(frozen=True, eq=False)
class InertialParameters:
    """π of a robot: `parameters` (10 · bodies,), 10 numbers per body in joint order, each
    [m, m cx, m cy, m cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] in the joint's frame (kg, kg·m, kg·m²,
    the inertia about the joint origin); `bodies` the joint names, `layout` the 10 names.
    τ = Y(q, v, a) π + armature ∘ a with Y = `client.regressor(...)`."""

    bodies: tuple[str, ...]
    layout: tuple[str, ...]
    parameters: np.ndarray

    def of(self, body: str) -> np.ndarray:
        """The 10 parameters of one body (by joint name)."""
        try:
            i = self.bodies.index(body)
        except ValueError:
            raise KeyError(f"no body is named {body!r}; bodies: {', '.join(self.bodies)}") from None
        return self.parameters[10 * i : 10 * (i + 1)]

    @classmethod
    def from_json(cls, body: Mapping[str, Any]) -> InertialParameters:
        return cls(tuple(body["bodies"]), tuple(body["layout"]), _vector(body["parameters"]))


@dataclass(frozen=True)
class IdentifiedBody:
    """One identified body: `mass` (kg), `center_of_mass` (3,) m and `inertia` (3, 3) kg·m²
    about the centre of mass, both in the joint frame; `pseudo_inertia_min_eigenvalue` ≥ 0
    for a physically possible body."""

    name: str
    mass: float
    center_of_mass: np.ndarray
    inertia: np.ndarray
    pseudo_inertia_min_eigenvalue: float


@dataclass(frozen=True)
class JointFriction:
    """τ_f = offset + coulomb sign(v) + viscous v for one joint (N·m or N, N·m·s/rad)."""

    joint: str
    coulomb: float
    viscous: float
    offset: float


@dataclass(frozen=True)
class IdentificationWarning:
    """What the log could not tell: `code` "unexcited_joint" names a `joint` whose motion does
    not determine its friction (it barely moves, or its speed stays near zero); `detail` says
    what the log shows of it."""

    code: str
    joint: str
    detail: str


@dataclass(frozen=True, eq=False)
class BaseParameters:
    """The identifiable combinations: `expressions` in the full parameters, their `values` and
    `standard_deviation`."""

    expressions: tuple[str, ...]
    values: np.ndarray
    standard_deviation: np.ndarray


class Rmse(NamedTuple):
    """Joint torque RMSE per joint (nv,), N·m or N."""

    train: np.ndarray
    validation: np.ndarray
    validation_before: np.ndarray


@dataclass(frozen=True, eq=False)
class Identification:
    """The answer of `identify`: the identified `parameters` (10 · bodies,) and `bodies`,
    `friction` per joint (None for a joint named in `warnings`: its motion does not determine
    its friction, which the stored variant leaves out), `warnings`, `base_parameters`,
    `condition_number` (None when the log leaves a base parameter undetermined),
    `physically_consistent`, `rmse` (train, validation, validation_before), `filter_hz` (None:
    the log was used as given), `samples`, the stored variant's `robot` (None without `store`,
    or when `not_stored` says why nothing was stored), and with a payload frame `payload` (a
    `Payload` usable in `payloads=` as it is). `validation_series` with `include_series`."""

    parameters: np.ndarray
    bodies: tuple[IdentifiedBody, ...]
    friction: tuple[JointFriction | None, ...]
    base_parameters: BaseParameters
    condition_number: float | None
    physically_consistent: bool
    rmse: Rmse
    filter_hz: float | None
    samples: Mapping[str, int]
    robot: RobotInfo | None
    payload: Payload | dict[str, Any] | None
    validation_series: Mapping[str, np.ndarray] | None
    not_stored: str | None = None
    warnings: tuple[IdentificationWarning, ...] = ()

    @property
    def robot_id(self) -> str | None:
        """The id of the stored identified robot (None when it was not stored)."""
        return None if self.robot is None else self.robot.id

    @classmethod
    def from_json(cls, body: Mapping[str, Any]) -> Identification:
        base = body["base_parameters"]
        payload = body.get("payload")
        series = body.get("validation_series")
        return cls(
            parameters=_vector(body["parameters"]),
            bodies=tuple(
                IdentifiedBody(
                    b["name"],
                    float(b["mass"]),
                    _vector(b["center_of_mass"]),
                    _vector(b["inertia"]),
                    float(b["pseudo_inertia_min_eigenvalue"]),
                )
                for b in body["bodies"]
            ),
            friction=tuple(
                None
                if f is None
                else JointFriction(
                    f["joint"], float(f["coulomb"]), float(f["viscous"]), float(f["offset"])
                )
                for f in body["friction"]
            ),
            base_parameters=BaseParameters(
                tuple(base["expressions"]),
                _vector(base["values"]),
                _vector(base["standard_deviation"]),
            ),
            condition_number=(
                None if body["condition_number"] is None else float(body["condition_number"])
            ),
            physically_consistent=bool(body["physically_consistent"]),
            rmse=Rmse(*(_vector(body["rmse"][k]) for k in Rmse._fields)),
            filter_hz=None if body["filter_hz"] is None else float(body["filter_hz"]),
            samples=dict(body["samples"]),
            robot=None if body.get("robot") is None else RobotInfo.from_json(body["robot"]),
            payload=None if payload is None else _payload(payload),
            validation_series=None
            if series is None
            else {k: _vector(v) for k, v in series.items()},
            not_stored=body.get("not_stored"),
            warnings=tuple(
                IdentificationWarning(w["code"], w["joint"], w["detail"])
                for w in body.get("warnings") or ()
            ),
        )
