"""Link inertials replaced in a built model and in a description's links (the inertia repairs
of `service.dynamics.model_check.repairs`, stored with an upload or a variant).

Pinocchio adds each link's inertial to the body of the joint that moves it, through the link's
body frame F (its placement in the joint frame): inertias[F.parentJoint] += F.placement ·
Inertia(m, c, I). Replacing a link's (m, c, I) by (m, c', I') is linear in the inertial
parameters π (`toDynamicParameters`: m, m c, the inertia about the joint origin):
π_body' = π_body − π(F · old) + π(F · new), exact whatever else the body carries. A repair
is a mapping {"link", "mass", "center_of_mass", "inertia", "declared": {"center_of_mass",
"inertia"}} (kg, m, kg·m² about the centre of mass, link axes).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from service.errors import InvalidModel
from service.registry.inertia_rules import ERROR_CODES
from service.registry.link_descriptions import LinkDescription
from service.registry.safe_xml import shown


def _parameters(mass: float, center: Any, inertia: Any, placement: Any) -> np.ndarray:
    body = pin.Inertia(
        float(mass), np.asarray(center, dtype=float), np.asarray(inertia, dtype=float)
    )
    return np.asarray(placement.act(body).toDynamicParameters(), dtype=float)


def _inertia(pi: np.ndarray) -> Any:
    if pi[0] == 0.0:  # a massless body: its rotational inertia, no centre of mass
        xx, xy, yy, xz, yz, zz = pi[4:]
        return pin.Inertia(0.0, np.zeros(3), np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]))
    return pin.Inertia.FromDynamicParameters(pi)


def with_link_inertias(model: Any, repairs: Sequence[Mapping[str, Any]]) -> Any:
    """A copy of `model` with each repaired link's inertial replaced (module docstring).
    `InvalidModel` naming a link that is not a body frame of the model."""
    out = pin.Model(model)
    for repair in repairs:
        link = str(repair["link"])
        if not out.existFrame(link, pin.FrameType.BODY):
            raise InvalidModel(f"link '{shown(link)}' is not a link of this model")
        frame = out.frames[out.getFrameId(link, pin.FrameType.BODY)]
        joint = frame.parentJoint
        pi = np.asarray(out.inertias[joint].toDynamicParameters(), dtype=float)
        declared = repair["declared"]
        mass = float(repair["mass"])
        pi -= _parameters(mass, declared["center_of_mass"], declared["inertia"], frame.placement)
        pi += _parameters(mass, repair["center_of_mass"], repair["inertia"], frame.placement)
        out.inertias[joint] = _inertia(pi)
    return out


def repaired_links(
    links: Sequence[LinkDescription], repairs: Sequence[Mapping[str, Any]]
) -> list[LinkDescription]:
    """`links` with each repair's centre of mass and inertia (the attributes as written are
    gone from a repaired link: None)."""
    by_link = {str(r["link"]): r for r in repairs}
    out = []
    for link in links:
        repair = by_link.get(link.name)
        if repair is not None:
            link = dataclasses.replace(
                link,
                center_of_mass=np.asarray(repair["center_of_mass"], dtype=float),
                inertia=np.asarray(repair["inertia"], dtype=float),
                attributes=None,
            )
        out.append(link)
    return out


def repaired_warnings(
    warnings: list[dict[str, Any]], repairs: Sequence[Mapping[str, Any]]
) -> list[dict[str, Any]]:
    """A robot's warnings after its inertia repairs (an upload's `inertia_check: "repair"`, a
    variant's `inertias`): the errors of repaired links replaced by one `inertia_repaired`
    each, saying what it does."""
    if not repairs:
        return warnings
    repaired = {r["link"]: r for r in repairs}
    kept = [w for w in warnings if not (w.get("code") in ERROR_CODES and w.get("name") in repaired)]
    return kept + [
        {
            "code": "inertia_repaired",
            "element": "link",
            "name": link,
            "message": f"link '{shown(link)}': "
            + (
                "centre of mass and inertia replaced by its geometry's with its mass "
                f"{r['mass']:.6g} kg"
                if r["from"] == "geometry"
                else "principal moments replaced by the nearest valid ones (centre of mass "
                "and principal axes kept)"
                if r["mass"] > 0
                else "inertia set to 0 (a massless link has none)"
            ),
        }
        for link, r in repaired.items()
    ]
