"""The model check of a robot (`GET /v1/robots/{id}/model-check`) and the repairs it plans.

`model_check(inputs)` answers {"findings": [...], "links": [...]}: the findings of every link
(`findings`: its error, else its warnings), then `mirror_asymmetry` for each left/right pair;
and one entry per link with mass, inertia or geometry,

    {"name", "mass" (kg), "center_of_mass" [3] (m, link frame),
     "principal_moments" [3] (kg·m², about the centre of mass, ascending),
     "inertia" 3×3 (kg·m², the declared tensor about the centre of mass, link axes),
     "geometry": {"source": "collision" | "visual", "volume" (m³), "density" (kg/m³: mass ÷
                  volume), "center_of_mass" [3] (m, link frame), "inertia" 3×3 (kg·m², about
                  the geometry's centre of mass, link axes, the declared mass spread
                  uniformly; null for a massless link)} or null}.

`planned_repairs(inputs, links, how)` gives the repairs (`repairs.repair_record`) of a variant
(`links`: names, "errors" or "all"; `how`: "geometry" or "nearest_valid") or, with `how`
"auto", of an upload with `inertia_check: "repair"`: every link with an error, from its
geometry where it has one, else the nearest valid tensor.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any

from service.dynamics.model_check.findings import (
    InertiaFinding,
    is_zero,
    link_error,
    link_warnings,
    mirror_finding,
    twins,
)
from service.dynamics.model_check.link_geometry import LinkShape, link_geometry
from service.dynamics.model_check.repairs import from_geometry, nearest_valid, repair_record
from service.errors import InvalidInput
from service.registry.check_inputs import CheckInputs
from service.registry.inertia_rules import principal_moments
from service.registry.link_descriptions import LinkDescription
from service.registry.safe_xml import shown


def _geometries(inputs: CheckInputs, links: list[LinkDescription]) -> list[LinkShape | None]:
    read = functools.lru_cache(maxsize=None)(inputs.read_mesh)  # a mesh shared by links: once
    return [link_geometry(link, read) for link in links]


def _listed(link: LinkDescription) -> bool:
    """A link with mass, inertia or geometry (the answer's `links`)."""
    return link.mass > 0.0 or not is_zero(link.inertia) or bool(link.collision or link.visual)


def _link_entry(link: LinkDescription, geometry: LinkShape | None) -> dict[str, Any]:
    shape = None
    if geometry is not None:
        props = geometry.properties
        shape = {
            "source": geometry.source,
            "volume": props.volume,
            "density": link.mass / props.volume,
            "center_of_mass": props.center.tolist(),
            "inertia": None
            if link.mass == 0.0
            else (props.inertia * (link.mass / props.volume)).tolist(),
        }
    return {
        "name": link.name,
        "mass": link.mass,
        "center_of_mass": link.center_of_mass.tolist(),
        "principal_moments": principal_moments(link.inertia).tolist(),
        "inertia": link.inertia.tolist(),
        "geometry": shape,
    }


def link_findings(
    links: Sequence[LinkDescription], geometries: Sequence[LinkShape | None]
) -> list[InertiaFinding]:
    """Every finding of `links` (with their geometries), link by link, then the twins'."""
    out: list[InertiaFinding] = []
    for link, geometry in zip(links, geometries, strict=True):
        error = link_error(link)
        out += [error] if error is not None else link_warnings(link, geometry)
    by_name = {link.name: link for link in links}
    for a, b in twins([link.name for link in links]):
        finding = mirror_finding(by_name[a], by_name[b])
        if finding is not None:
            out.append(finding)
    return out


def model_check(inputs: CheckInputs) -> dict[str, Any]:
    """The model check's answer (module docstring). Reads meshes: run it where untrusted
    files may be parsed (a child process)."""
    links = inputs.links()
    geometries = _geometries(inputs, links)
    return {
        "findings": [f.as_dict() for f in link_findings(links, geometries)],
        "links": [
            _link_entry(link, geometry)
            for link, geometry in zip(links, geometries, strict=True)
            if _listed(link)
        ],
    }


def planned_repairs(
    inputs: CheckInputs, selection: str | Sequence[str], how: str
) -> list[dict[str, Any]]:
    """The repairs of the selected links (module docstring). `InvalidInput` (422) for a name
    that is not a link of the robot, or `how` "geometry" on a link without geometry."""
    links = inputs.links()
    geometries = _geometries(inputs, links)
    pairs = list(zip(links, geometries, strict=True))
    listed = [pair for pair in pairs if _listed(pair[0])]
    if selection == "errors" or how == "auto":
        chosen = [pair for pair in listed if link_error(pair[0]) is not None]
    elif selection == "all":
        chosen = listed
    else:
        by_name = {pair[0].name: pair for pair in pairs}
        unknown = [name for name in selection if name not in by_name]
        if unknown:
            raise InvalidInput(
                f"inertias.links: '{shown(unknown[0])}' is not a link of this robot "
                "(GET .../model-check lists them)"
            )
        chosen = [by_name[name] for name in dict.fromkeys(selection)]
    out = []
    for link, geometry in chosen:
        if how == "geometry" and geometry is None:
            raise InvalidInput(
                f"link '{shown(link.name)}' has no geometry (no collision or visual shape "
                'whose volume is known): repair it with "from": "nearest_valid"'
            )
        use_geometry = geometry is not None and how in ("geometry", "auto")
        if use_geometry and geometry is not None:
            center, inertia = from_geometry(link, geometry)
        else:
            center, inertia = nearest_valid(link)
        out.append(
            repair_record(link, "geometry" if use_geometry else "nearest_valid", center, inertia)
        )
    return out
