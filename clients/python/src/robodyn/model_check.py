"""The answer of `model_check(id)`: the inertias a robot's description claims, against physics
and each link's own geometry (frozen dataclasses; arrays are float64 numpy arrays, SI units)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class ModelCheckFinding:
    """One finding: `code` (e.g. "triangle_inequality"), `severity` ("error": no rigid body
    has it; "warning": possible, rarely meant), `link`, `message`, and for an error that one
    inertia attribute off by a power of ten explains, `suggestion` {"attribute", "value"}."""

    code: str
    severity: str
    link: str
    message: str
    suggestion: Mapping[str, Any] | None

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> ModelCheckFinding:
        return cls(
            code=str(data["code"]),
            severity=str(data["severity"]),
            link=str(data["link"]),
            message=str(data["message"]),
            suggestion=data.get("suggestion"),
        )


@dataclass(frozen=True, eq=False)
class LinkGeometry:
    """The mass properties of a link's shape (`source` "collision" or "visual"): `volume` (m³),
    `density` (the link's mass ÷ volume, kg/m³), `center_of_mass` (3,) m in the link frame,
    `inertia` (3, 3) kg·m² about it with the link's mass spread uniformly (None when
    massless)."""

    source: str
    volume: float
    density: float
    center_of_mass: np.ndarray
    inertia: np.ndarray | None

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> LinkGeometry:
        inertia = data.get("inertia")
        return cls(
            source=str(data["source"]),
            volume=float(data["volume"]),
            density=float(data["density"]),
            center_of_mass=np.asarray(data["center_of_mass"], dtype=np.float64),
            inertia=None if inertia is None else np.asarray(inertia, dtype=np.float64),
        )


@dataclass(frozen=True, eq=False)
class LinkCheck:
    """A link as declared: `mass` (kg), `center_of_mass` (3,) m in the link frame,
    `principal_moments` (3,) kg·m² ascending, `inertia` (3, 3) kg·m² about the centre of mass
    in the link axes, and its `geometry` (None without a shape)."""

    name: str
    mass: float
    center_of_mass: np.ndarray
    principal_moments: np.ndarray
    inertia: np.ndarray
    geometry: LinkGeometry | None

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> LinkCheck:
        geometry = data.get("geometry")
        return cls(
            name=str(data["name"]),
            mass=float(data["mass"]),
            center_of_mass=np.asarray(data["center_of_mass"], dtype=np.float64),
            principal_moments=np.asarray(data["principal_moments"], dtype=np.float64),
            inertia=np.asarray(data["inertia"], dtype=np.float64),
            geometry=None if geometry is None else LinkGeometry.from_json(geometry),
        )


@dataclass(frozen=True, eq=False)
class ModelCheck:
    """`findings` (errors and warnings) and `links` (one per link with mass or geometry);
    `errors` are the findings of severity "error", `links_by_name` the links by name."""

    findings: tuple[ModelCheckFinding, ...]
    links: tuple[LinkCheck, ...]

    @property
    def errors(self) -> tuple[ModelCheckFinding, ...]:
        return tuple(f for f in self.findings if f.severity == "error")

    @property
    def links_by_name(self) -> dict[str, LinkCheck]:
        return {link.name: link for link in self.links}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> ModelCheck:
        return cls(
            findings=tuple(ModelCheckFinding.from_json(f) for f in data["findings"]),
            links=tuple(LinkCheck.from_json(link) for link in data["links"]),
        )
