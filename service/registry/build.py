"""Building Pinocchio models from description text (the only place the native parsers run).

`validate_description` checks URDF or MJCF text with robodyn's own validators (`urdf_check`,
`mjcf_check`); `build_urdf_model` runs the native URDF parser on text that `urdf_check` has
already validated, `build_mjcf_model` the native MJCF parser on text that `mjcf_check`
validates (again) first. For uploads both run in a builder process
(`service.registry.build_process`), never in the serving process; stored and catalog models,
validated before, are rebuilt here in process.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from service.errors import InvalidModel
from service.registry.mjcf_check import MJCFSummary, check_mjcf
from service.registry.mjcf_split import pinocchio_text
from service.registry.urdf_check import Finding, Limits, check_urdf

ROOT_JOINTS = ("fixed", "free-flyer", "planar")
FORMATS = ("urdf", "mjcf")
_PRISMATIC = ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned")
_UNBOUNDED = ("JointModelFreeFlyer", "JointModelSpherical")
_MAX = float(np.finfo(np.float64).max)


def root_joint_model(root_joint: str) -> Any | None:
    """The Pinocchio joint that attaches the description's root link to the world."""
    if root_joint == "fixed":
        return None
    if root_joint == "free-flyer":
        return pin.JointModelFreeFlyer()
    if root_joint == "planar":
        return pin.JointModelPlanar()
    raise ValueError(f"root_joint must be one of {ROOT_JOINTS}")


def build_urdf_model(text: str, root_joint: str, gravity: Sequence[float] | None = None) -> Any:
    """Parse validated URDF text into a `pin.Model` (kinematics and inertias; no geometry)."""
    joint = root_joint_model(root_joint)
    model = pin.buildModelFromXML(text) if joint is None else pin.buildModelFromXML(text, joint)
    _set_gravity(model, gravity)
    return model


def _set_gravity(model: Any, gravity: Sequence[float] | None) -> None:
    if gravity is not None:
        model.gravity = pin.Motion(np.asarray(gravity, dtype=float), np.zeros(3))


def _fix_mjcf_limits(model: Any, angle_in_degrees: bool) -> None:
    """Undo two quirks of Pinocchio's MJCF limits: slide ranges scaled by π/180 in degree mode,
    and ±1.01 on free and ball joints (served, like URDF root joints, as unbounded)."""
    lower, upper = model.lowerPositionLimit.copy(), model.upperPositionLimit.copy()
    for jid in range(1, model.njoints):
        jm = model.joints[jid]
        q = slice(jm.idx_q, jm.idx_q + jm.nq)
        if jm.shortname() in _PRISMATIC and angle_in_degrees:
            lower[q] *= 180.0 / math.pi
            upper[q] *= 180.0 / math.pi
        elif jm.shortname() in _UNBOUNDED:
            lower[q], upper[q] = -_MAX, _MAX
    model.lowerPositionLimit, model.upperPositionLimit = lower, upper


@contextmanager
def mjcf_source(text: str, root_joint: str, summary: MJCFSummary | None = None
                ) -> Iterator[tuple[Path, MJCFSummary]]:
    """Validate MJCF text (`check_mjcf`, which also decides the root: a free joint on the top
    body is its own root; otherwise `root_joint` is added above a joint-less top body; skipped
    when its `summary` is given) and write the text Pinocchio is given (`mjcf_split`: bodies
    with several joints become chains) to a private temporary file, removed on exit:
    Pinocchio's MJCF parser reads files only.

    In the builder child this runs before the limit on file writes is set.
    """
    summary = summary or check_mjcf(text, root_joint)
    with tempfile.TemporaryDirectory(prefix="robodyn-mjcf-") as tmp:
        path = Path(tmp) / "model.xml"
        path.write_text(pinocchio_text(text), encoding="utf-8")
        yield path, summary


def build_mjcf_file(path: Path, summary: MJCFSummary,
                    gravity: Sequence[float] | None = None) -> Any:
    """Parse the file `mjcf_source` wrote into a `pin.Model` (kinematics and inertias; meshes
    and textures are never read)."""
    joint = root_joint_model(summary.added_root_joint)
    model = (pin.buildModelFromMJCF(str(path)) if joint is None
             else pin.buildModelFromMJCFAndRootJoint(str(path), joint, "root_joint"))
    _fix_mjcf_limits(model, summary.angle_in_degrees)
    _set_gravity(model, gravity)
    return model


def build_mjcf_model(text: str, root_joint: str, gravity: Sequence[float] | None = None) -> Any:
    """Validate and parse MJCF text into a `pin.Model` (`mjcf_source`, then `build_mjcf_file`)."""
    with mjcf_source(text, root_joint) as (path, summary):
        return build_mjcf_file(path, summary, gravity)


def build_model(description_format: str, text: str, root_joint: str,
                gravity: Sequence[float] | None = None) -> Any:
    """Build a model from validated URDF or MJCF text (`description_format`: "urdf"/"mjcf")."""
    if description_format == "mjcf":
        return build_mjcf_model(text, root_joint, gravity)
    if description_format == "urdf":
        return build_urdf_model(text, root_joint, gravity)
    raise ValueError(f"description_format must be one of {FORMATS}")


def reference_configurations(model: Any) -> dict[str, np.ndarray]:
    """The model's named configurations (MJCF keyframes and "qpos0"), normalized."""
    return {entry.key(): pin.normalize(model, np.array(entry.data(), dtype=float))
            for entry in model.referenceConfigurations}


def check_moves(model: Any) -> None:
    """Reject a model without any velocity coordinate (nv = 0: only fixed joints and a fixed
    root): it has no dynamics, and several of Pinocchio's algorithms (frame Jacobians) crash
    the process on it instead of answering."""
    if model.nv == 0:
        raise InvalidModel("the model has no moving joint (nv = 0), so it has no dynamics to "
                           'compute; give it a moving joint, or a root joint ("root_joint": '
                           '"free-flyer" or "planar")')


def check_subtree_masses(model: Any) -> None:
    """Reject a model with a moving joint whose subtree carries no mass (M singular)."""
    data = model.createData()
    pin.computeSubtreeMasses(model, data)
    for jid in range(1, model.njoints):
        if model.joints[jid].nv and data.mass[jid] <= 0.0:
            raise InvalidModel(f"joint '{model.names[jid]}' moves a subtree without mass: the "
                               "mass matrix is singular")


def check_mass_matrix(model: Any) -> None:
    """Reject a model whose mass matrix at the neutral configuration is not positive definite."""
    data = model.createData()
    M = pin.crba(model, data, pin.neutral(model))
    M = np.triu(M) + np.triu(M, 1).T
    if not np.all(np.isfinite(M)):
        raise InvalidModel("the mass matrix at the neutral configuration is not finite")
    if model.nv and np.linalg.eigvalsh(M)[0] <= 0.0:
        raise InvalidModel("the mass matrix at the neutral configuration is not positive "
                           "definite (a moving body without mass or inertia)")


@dataclass(frozen=True)
class Checked:
    """What validation of a description found: physical `findings` (rejected unless the
    upload asks for warnings), `notes` (always warnings), the description's own name `label`
    and the root joint as served (MJCF: a free joint on the top body is its own root)."""

    findings: list[Finding] = field(default_factory=list)
    notes: list[Finding] = field(default_factory=list)
    label: str = ""
    root_joint: str = "fixed"


def validate_description(description_format: str, text: str, root_joint: str,
                         limits: Limits) -> tuple[Checked, MJCFSummary | None]:
    """Validate URDF or MJCF text (raises `InvalidModel` naming the element at fault): what it
    found, and for MJCF the summary the build needs."""
    if description_format == "mjcf":
        mjcf = check_mjcf(text, root_joint, limits)
        return Checked(mjcf.findings, mjcf.notes, mjcf.robot_name, mjcf.root_joint), mjcf
    if description_format == "urdf":
        urdf = check_urdf(text, limits)
        return Checked(urdf.findings, [], urdf.robot_name, root_joint), None
    raise ValueError(f"description_format must be one of {FORMATS}")
