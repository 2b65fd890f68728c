"""Operational-space references for the tests of the service and of the client: Λ, J̄, μ, p
straight from Khatib's formulas with numpy, and from in-process Pinocchio building blocks,
computed independently of the service's code path (M from CRBA and numpy instead of
computeMinverse, Λ by numpy inversion instead of an eigen-decomposition); the reference frames,
task rows and the singularity threshold of the API."""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from tests.helpers import mass_matrix

RF = {
    "world": pin.ReferenceFrame.WORLD,
    "local": pin.ReferenceFrame.LOCAL,
    "local_world_aligned": pin.ReferenceFrame.LOCAL_WORLD_ALIGNED,
}
ROWS = {"full": slice(0, 6), "linear": slice(0, 3), "angular": slice(3, 6)}
SINGULAR_RCOND = 1e-8  # the documented threshold (README, OpenAPI `damping`)


def task_matrix(M: np.ndarray, J: np.ndarray) -> np.ndarray:
    """A = J M⁻¹ Jᵀ by numpy (a linear solve with M)."""
    return J @ np.linalg.solve(M, J.T)


def singular_ratio(M: np.ndarray, J: np.ndarray) -> float:
    """σ_min / σ_max of J M⁻¹ Jᵀ (0 for a zero Jacobian)."""
    sigma = np.linalg.eigvalsh(task_matrix(M, J))
    return float(sigma[0] / sigma[-1]) if sigma[-1] > 0 else 0.0


def khatib_formulas(
    M: np.ndarray,
    J: np.ndarray,
    dJ: np.ndarray | None,
    C: np.ndarray | None,
    g: np.ndarray,
    v: np.ndarray | None,
    damping: float = 0.0,
) -> dict[str, np.ndarray]:
    """Λ, J̄, p (and μ) straight from the formulas, with numpy, from M, J, J̇, C, g."""
    Minv = np.linalg.inv(M)
    A = J @ Minv @ J.T + damping**2 * np.eye(J.shape[0])
    Lambda = np.linalg.inv(A)
    Jbar = Minv @ J.T @ Lambda
    out = {
        "inertia": Lambda,
        "jacobian": J,
        "dynamically_consistent_inverse": Jbar,
        "gravity": Jbar.T @ g,
    }
    if v is not None and C is not None and dJ is not None:
        out["coriolis"] = Jbar.T @ C @ v - Lambda @ dJ @ v
    return out


def pinocchio_operational_space(
    model: Any,
    q: np.ndarray,
    v: np.ndarray | None,
    frame: str,
    reference_frame: str = "local_world_aligned",
    task: str = "full",
    damping: float = 0.0,
) -> dict[str, np.ndarray]:
    """The same quantities from in-process Pinocchio building blocks (CRBA, frame Jacobian and
    its time variation, Coriolis matrix, generalized gravity)."""
    data = model.createData()
    fid = model.getFrameId(frame)
    rows = ROWS[task]
    M = mass_matrix(model, q)
    g = pin.computeGeneralizedGravity(model, data, q).copy()
    if v is None:
        J = pin.computeFrameJacobian(model, data, q, fid, RF[reference_frame])[rows]
        return khatib_formulas(M, J, None, None, g, None, damping)
    pin.computeJointJacobiansTimeVariation(model, data, q, v)
    pin.updateFramePlacements(model, data)
    J = pin.getFrameJacobian(model, data, fid, RF[reference_frame])[rows].copy()
    dJ = pin.getFrameJacobianTimeVariation(model, data, fid, RF[reference_frame])[rows].copy()
    C = pin.computeCoriolisMatrix(model, data, q, v).copy()
    return khatib_formulas(M, J, dJ, C, g, v, damping)
