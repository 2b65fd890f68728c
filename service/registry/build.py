"""Building Pinocchio models from description text (the only place the native parsers run).

`validate_urdf` checks URDF text with robodyn's own validator (`urdf_check`);
`build_urdf_model` runs the native URDF parser on text it has validated, `build_mjcf_model`
MuJoCo's compiler on MJCF that `mjcf_compile.preflight` has checked. For uploads all of it runs
in a builder process (`service.registry.build_process`), never in the serving process; stored
and catalog models, validated before, are rebuilt here in process.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from service.errors import InvalidModel
from service.registry.mjcf_build import MJCFModel, pinocchio_model
from service.registry.mjcf_compile import compile_mjcf
from service.registry.mjcf_visuals import mjcf_visuals
from service.registry.urdf_check import Finding, Limits, check_urdf

ROOT_JOINTS = ("fixed", "free-flyer", "planar")
FORMATS = ("urdf", "mjcf", "xacro")


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


def build_mjcf_model(
    text: str,
    root_joint: str,
    gravity: Sequence[float] | None = None,
    assets: Mapping[str, bytes] | None = None,
) -> MJCFModel:
    """Compile MJCF text with MuJoCo (`mjcf_compile`, assets in memory) and build its Pinocchio
    model body by body (`mjcf_build`) and its visuals (`mjcf_visuals`); gravity defaults to the
    model's own."""
    mj = compile_mjcf(text, assets or {})
    built = pinocchio_model(mj, root_joint, gravity)
    built.visuals = mjcf_visuals(mj, built.body_frames)
    return built


def build_model(
    description_format: str,
    text: str,
    root_joint: str,
    gravity: Sequence[float] | None = None,
    assets: Mapping[str, bytes] | None = None,
) -> Any:
    """Build a model from validated URDF or MJCF text (`description_format`: "urdf"/"mjcf")."""
    if description_format == "mjcf":
        return build_mjcf_model(text, root_joint, gravity, assets).model
    if description_format == "urdf":
        return build_urdf_model(text, root_joint, gravity)
    raise ValueError(f"description_format must be one of {FORMATS}")


def reference_configurations(model: Any) -> dict[str, np.ndarray]:
    """The model's named configurations (MJCF keyframes and "qpos0"), normalized."""
    return {
        entry.key(): pin.normalize(model, np.array(entry.data(), dtype=float))
        for entry in model.referenceConfigurations
    }


def check_moves(model: Any) -> None:
    """Reject a model without any velocity coordinate (nv = 0: only fixed joints and a fixed
    root): it has no dynamics, and several of Pinocchio's algorithms (frame Jacobians) crash
    the process on it instead of answering."""
    if model.nv == 0:
        raise InvalidModel(
            "the model has no moving joint (nv = 0), so it has no dynamics to "
            'compute; give it a moving joint, or a root joint ("root_joint": '
            '"free-flyer" or "planar")'
        )


def check_subtree_masses(model: Any) -> None:
    """Reject a model with a moving joint whose subtree carries no mass (M singular)."""
    data = model.createData()
    pin.computeSubtreeMasses(model, data)
    for jid in range(1, model.njoints):
        if model.joints[jid].nv and data.mass[jid] <= 0.0:
            raise InvalidModel(
                f"joint '{model.names[jid]}' moves a subtree without mass: the "
                "mass matrix is singular"
            )


def check_mass_matrix(model: Any) -> None:
    """Reject a model whose mass matrix at the neutral configuration is not positive definite."""
    data = model.createData()
    M = pin.crba(model, data, pin.neutral(model))
    M = np.triu(M) + np.triu(M, 1).T
    if not np.all(np.isfinite(M)):
        raise InvalidModel("the mass matrix at the neutral configuration is not finite")
    if model.nv and np.linalg.eigvalsh(M)[0] <= 0.0:
        raise InvalidModel(
            "the mass matrix at the neutral configuration is not positive "
            "definite (a moving body without mass or inertia)"
        )


@dataclass(frozen=True)
class Checked:
    """What validation of a description found: physical `findings` (rejected unless the
    upload asks for warnings), `notes` (always warnings), the description's own name `label`
    and the root joint as served (MJCF: a free joint on the top body is its own root)."""

    findings: list[Finding] = field(default_factory=list)
    notes: list[Finding] = field(default_factory=list)
    label: str = ""
    root_joint: str = "fixed"


def validate_urdf(text: str, root_joint: str, limits: Limits) -> Checked:
    """Validate URDF text (raises `InvalidModel` naming the element at fault): what it found."""
    urdf = check_urdf(text, limits)
    return Checked(urdf.findings, [], urdf.robot_name, root_joint)
