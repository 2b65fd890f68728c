"""The findings of the model check on one link, or on a left/right pair of links.

Errors (no rigid body has them; `service.registry.inertia_rules`, the rules uploads apply):
`negative_principal_moment`, `triangle_inequality`, `inertia_without_mass`, with the
power-of-ten `suggestion` where exactly one attribute explains the error. Warnings (possible,
rarely meant), judged on links without error (`mirror_asymmetry` on every pair):

- `point_mass_with_geometry`: mass > 0, inertia 0, and the link has geometry;
- `massless_with_geometry`: mass 0, collision geometry, and the link moves;
- `implausible_density`: mass ÷ geometry volume outside [100, 25,000] kg/m³ (from foams and
  hollow covers to tungsten);
- `center_of_mass_outside_geometry`: outside the geometry's bounding box (link frame) grown
  by 10 % of its diagonal on every side;
- `inertia_geometry_mismatch`: a principal moment over 10 × or under 1/10 of the geometry's
  with the declared mass (the i-th smallest against the i-th smallest), on links that are not
  point masses;
- `open_mesh`: a mesh of the geometry is not closed; its convex hull stands in for it;
- `mirror_asymmetry` (a pair): `twins` below, with equal masses (1e-9 relative) and a
  principal moment differing by more than half of the larger one.
"""

from __future__ import annotations

import posixpath
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from service.dynamics.model_check.link_geometry import LinkShape
from service.registry.inertia_rules import (
    ABS_TOL,
    inertia_error,
    power_of_ten_fix,
    principal_moments,
)
from service.registry.link_descriptions import LinkDescription
from service.registry.safe_xml import shown

DENSITY_RANGE = (100.0, 25_000.0)  # kg/m³
BOX_GROWTH = 0.10  # of the bounding box's diagonal
MISMATCH_FACTOR = 10.0
TWIN_MASS_REL_TOL = 1e-9
TWIN_MOMENT_REL_DIFF = 0.5  # of the larger moment


@dataclass(frozen=True)
class InertiaFinding:
    """One finding: `code`, `severity` ("error" or "warning"), `link`, `message`, and the
    power-of-ten `suggestion` {"attribute", "value"} or None."""

    code: str
    severity: str
    link: str
    message: str
    suggestion: dict[str, Any] | None = None

    def as_dict(self) -> dict[str, Any]:
        return {
            "code": self.code,
            "severity": self.severity,
            "link": self.link,
            "message": self.message,
            "suggestion": self.suggestion,
        }


def is_zero(inertia: np.ndarray) -> bool:
    return bool(np.max(np.abs(inertia)) <= ABS_TOL)


def link_error(link: LinkDescription) -> InertiaFinding | None:
    """The error of a link's inertial, with its suggestion, or None."""
    error = inertia_error(link.mass, link.inertia)
    if error is None:
        return None
    fix = None if link.attributes is None else power_of_ten_fix(link.mass, link.attributes)
    suggestion = None if fix is None else {"attribute": fix[0], "value": fix[1]}
    message = f"link '{shown(link.name)}': {error.what}"
    if fix is not None:
        message += f"; {fix[0]} = {fix[1]:.12g} (the written value times a power of ten) fixes it"
    return InertiaFinding(error.code, "error", link.name, message, suggestion)


def link_warnings(link: LinkDescription, geometry: LinkShape | None) -> list[InertiaFinding]:
    """The warnings of a link without error, in the module docstring's order."""
    name = shown(link.name)
    out: list[InertiaFinding] = []

    def warn(code: str, message: str) -> None:
        out.append(InertiaFinding(code, "warning", link.name, f"link '{name}': {message}"))

    has_geometry = bool(link.collision or link.visual)
    point_mass = link.mass > 0.0 and is_zero(link.inertia)
    if point_mass and has_geometry:
        warn(
            "point_mass_with_geometry",
            f"mass {link.mass:.6g} kg with zero inertia, but the link has a shape",
        )
    if link.mass == 0.0 and link.collision and link.moves:
        warn("massless_with_geometry", "no mass, but it moves and has collision geometry")
    if geometry is not None and link.mass > 0.0:
        props = geometry.properties
        density = link.mass / props.volume
        if not DENSITY_RANGE[0] <= density <= DENSITY_RANGE[1]:
            warn(
                "implausible_density",
                f"mass {link.mass:.6g} kg in a {geometry.source} volume of {props.volume:.6g} m³ "
                f"is {density:.6g} kg/m³, outside [{DENSITY_RANGE[0]:g}, {DENSITY_RANGE[1]:g}]",
            )
        grow = BOX_GROWTH * float(np.linalg.norm(props.bounds[1] - props.bounds[0]))
        low, high = props.bounds[0] - grow, props.bounds[1] + grow
        c = link.center_of_mass
        if np.any(c < low) or np.any(c > high):
            shown_c = ", ".join(f"{x:.6g}" for x in c)
            warn(
                "center_of_mass_outside_geometry",
                f"centre of mass [{shown_c}] m is outside its {geometry.source} geometry's "
                f"bounding box grown by {BOX_GROWTH:.0%} of its diagonal",
            )
        if not point_mass:
            declared = principal_moments(link.inertia)
            shaped = principal_moments(props.inertia * link.mass / props.volume)
            off = [
                i
                for i in range(3)
                if declared[i] > MISMATCH_FACTOR * shaped[i]
                or declared[i] * MISMATCH_FACTOR < shaped[i]
            ]
            if off:
                i = off[0]
                warn(
                    "inertia_geometry_mismatch",
                    f"principal moment {declared[i]:.6g} kg·m² against {shaped[i]:.6g} for its "
                    f"{geometry.source} geometry with the same mass (more than "
                    f"{MISMATCH_FACTOR:g}× apart)",
                )
    if geometry is not None and geometry.open_meshes:
        meshes = ", ".join(f"'{shown(posixpath.basename(m))}'" for m in geometry.open_meshes[:5])
        warn("open_mesh", f"mesh {meshes} is not closed: its convex hull is used")
    return out


_TOKEN = re.compile(r"[A-Z]?[a-z]+|[A-Z]+(?![a-z])|\d+")
_SIDES = {"left": ("L", "word"), "right": ("R", "word"), "l": ("L", "letter"), "r": ("R", "letter")}


def side_key(name: str) -> tuple[str, tuple[str, ...]] | None:
    """(the name with its left/right markers replaced by their form, the sides in order), or
    None without a marker. A marker is left/right or l/r (any case) as a word: a part between
    `_`, `-`, `.`, digits or a lower-to-upper case change (`l_hip`, `LHipYaw`, `arm_left_1`)."""
    key, sides, last = [], [], 0
    for match in _TOKEN.finditer(name):
        side = _SIDES.get(match.group().lower())
        if side is None:
            continue
        key.append(name[last : match.start()] + "{" + side[1] + "}")
        sides.append(side[0])
        last = match.end()
    if not sides:
        return None
    key.append(name[last:])
    return "".join(key), tuple(sides)


def twins(names: list[str]) -> list[tuple[str, str]]:
    """Pairs of names that differ only in left/right markers, each side swapped (document
    order within a pair)."""
    seen: dict[tuple[str, tuple[str, ...]], str] = {}
    pairs = []
    for name in names:
        key = side_key(name)
        if key is None:
            continue
        swapped = (key[0], tuple("R" if s == "L" else "L" for s in key[1]))
        if swapped in seen:
            pairs.append((seen[swapped], name))
        seen.setdefault(key, name)
    return pairs


def mirror_finding(a: LinkDescription, b: LinkDescription) -> InertiaFinding | None:
    """`mirror_asymmetry` for twins with equal masses whose principal moments differ by more
    than half of the larger one."""
    if not (a.mass > 0.0 and abs(a.mass - b.mass) <= TWIN_MASS_REL_TOL * max(a.mass, b.mass)):
        return None
    la, lb = principal_moments(a.inertia), principal_moments(b.inertia)
    differ = np.abs(la - lb) > TWIN_MOMENT_REL_DIFF * np.maximum(np.abs(la), np.abs(lb))
    if not np.any(differ):
        return None
    shown_a = ", ".join(f"{x:.6g}" for x in la)
    shown_b = ", ".join(f"{x:.6g}" for x in lb)
    return InertiaFinding(
        "mirror_asymmetry",
        "warning",
        a.name,
        f"link '{shown(a.name)}' and its twin '{shown(b.name)}' have the same mass "
        f"{a.mass:.6g} kg but principal moments [{shown_a}] and [{shown_b}] kg·m²",
    )
