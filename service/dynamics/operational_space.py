"""Operational-space (task-space) dynamics of a frame, after Khatib (1987).

With J the task Jacobian (k×nv: the rows of the frame Jacobian that `task` selects), the joint
dynamics M a + C v + g = τ seen through the task acceleration ẍ = J a + J̇ v under a task force
F (τ = Jᵀ F) read

    Λ ẍ + μ + p = F,   Λ = (J M⁻¹ Jᵀ)⁻¹,   J̄ = M⁻¹ Jᵀ Λ,   μ = J̄ᵀ C v − Λ J̇ v,   p = J̄ᵀ g,

with Λ the task-space inertia (k×k), J̄ the dynamically consistent generalized inverse of J
(nv×k, J J̄ = I), μ the task-space Coriolis/centrifugal force and p the task-space gravity (k).
Rows: `task` "full" is the 6-D [linear; angular], "linear" the 3 linear rows and "angular"
the 3 angular ones, all in `reference_frame` (see `service.dynamics.frames`). Units: Λ in kg
(linear rows) and kg·m² (angular rows), μ and p in N and N·m.

M⁻¹ comes from Pinocchio's computeMinverse (M is never inverted numerically). The k×k matrix
A = J M⁻¹ Jᵀ is symmetric positive semi-definite; its singular values are its eigenvalues
σ_min ≤ … ≤ σ_max. The configuration is singular for the task when σ_min ≤ SINGULAR_RCOND ·
σ_max (condition number ≥ 1e8: a task direction the joints can barely move), and the answer is
`SingularConfiguration` unless a damping λ > 0 is given; then Λ = (A + λ² I)⁻¹, which stays
bounded (‖Λ‖ ≤ 1/λ²), and only a damped matrix that is still singular by the same test (λ² far
below the rounding level of σ_max) is refused.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
import pinocchio as pin

from service.dynamics.frames import REFERENCE_FRAMES, ReferenceFrame, frame_id, frame_jacobian
from service.dynamics.lagrangian import minverse
from service.dynamics.quantity import Quantity, Results, finite
from service.errors import InvalidInput, SingularConfiguration
from service.registry.robot import Robot
from service.states import States

Task = Literal["full", "linear", "angular"]

TASK_ROWS: dict[str, slice] = {"full": slice(0, 6), "linear": slice(0, 3), "angular": slice(3, 6)}

SINGULAR_RCOND = 1e-8
"""A task matrix J M⁻¹ Jᵀ whose smallest singular value is at most this times its largest is
singular (relative, so the test does not depend on the robot's size or mass)."""


def _singular(
    state: int | None,
    frame: str,
    task: str,
    reference_frame: str,
    sigma: np.ndarray,
    damping: float,
) -> SingularConfiguration:
    # A is positive semi-definite: a negative eigenvalue is rounding, i.e. a singular value 0.
    smallest, largest = max(float(sigma[0]), 0.0), max(float(sigma[-1]), 0.0)
    ratio = smallest / largest if largest > 0 else 0.0
    condition = largest / smallest if smallest > 0 else None
    shown = f"{condition:.3g}" if condition is not None else "infinite"
    if largest <= 0:
        why = f"the Jacobian of frame '{frame}' is zero here (no joint moves it)"
    elif smallest <= 0:
        why = (
            f"it has lost rank: its smallest singular value is 0 to rounding, its largest "
            f"{largest:.3g} (condition number infinite; robodyn treats a ratio of at most "
            f"{SINGULAR_RCOND:g} as singular)"
        )
    else:
        why = (
            f"its smallest singular value {smallest:.3g} is {ratio:.3g} times its largest "
            f"{largest:.3g} (condition number {shown}; robodyn treats a ratio of at most "
            f"{SINGULAR_RCOND:g} as singular)"
        )
    fix = (
        'give "damping": λ > 0 to use (J M⁻¹ Jᵀ + λ² I)⁻¹ instead'
        if damping == 0
        else f'"damping" {damping:g} is too small to regularize it; use a larger λ'
    )
    where = f"state {state}: " if state is not None else ""
    extra = {"state": state} if state is not None else {}
    return SingularConfiguration(
        f"{where}the task matrix J M⁻¹ Jᵀ of frame '{frame}' ({task} task, {reference_frame}) "
        f"is singular: {why}; {fix}",
        smallest_singular_value=smallest,
        largest_singular_value=largest,
        condition_number=condition,
        **extra,
    )


def _task_inertia(sigma: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Λ = V diag(1/σ) Vᵀ from the eigen-decomposition of (J M⁻¹ Jᵀ + λ² I): symmetric."""
    inertia: np.ndarray = (vectors / sigma) @ vectors.T
    return inertia


def operational_space(
    robot: Robot,
    s: States,
    *,
    frame: str,
    reference_frame: ReferenceFrame = "local_world_aligned",
    task: Task = "full",
    damping: float = 0.0,
) -> Results:
    """Operational-space dynamics of `frame` for `task` (k = 6 rows for "full", 3 otherwise):
    Λ (N, k, k), J (N, k, nv), J̄ (N, nv, k), p (N, k) and with v also μ (N, k).
    `SingularConfiguration` at a singular configuration unless `damping` λ > 0."""
    fid = frame_id(robot, frame)
    reference = REFERENCE_FRAMES[reference_frame]
    rows = TASK_ROWS[task]
    q = s["q"]
    v = s.arrays.get("v")
    n, nv = q.shape[0], robot.nv
    k = rows.stop - rows.start
    out: dict[str, np.ndarray] = {
        "inertia": np.empty((n, k, k)),
        "jacobian": np.empty((n, k, nv)),
        "dynamically_consistent_inverse": np.empty((n, nv, k)),
        "gravity": np.empty((n, k)),
    }
    if v is not None:
        out["coriolis"] = np.empty((n, k))
    model = robot.model
    damping2 = damping * damping
    if not np.isfinite(damping2):
        raise InvalidInput(f"damping {damping:g} is too large: λ² is not a finite number")
    with robot.data() as data:
        for i in range(n):
            J, dJ = frame_jacobian(robot, data, q[i], fid, reference, None if v is None else v[i])
            J = J[rows]
            Minv = minverse(robot, data, q[i])
            finite("operational-space", mass_matrix_inverse=Minv)
            MinvJt = Minv @ J.T
            A = J @ MinvJt
            A = 0.5 * (A + A.T) + damping2 * np.eye(k)
            sigma, vectors = np.linalg.eigh(A)
            if not sigma[0] > SINGULAR_RCOND * sigma[-1]:
                raise _singular(
                    s.first + i if s.batched else None, frame, task, reference_frame, sigma, damping
                )
            Lambda = _task_inertia(sigma, vectors)
            Jbar = MinvJt @ Lambda
            g = np.array(pin.computeGeneralizedGravity(model, data, q[i]))
            out["inertia"][i], out["jacobian"][i] = Lambda, J
            out["dynamically_consistent_inverse"][i], out["gravity"][i] = Jbar, Jbar.T @ g
            if v is not None and dJ is not None:
                Cv = np.array(pin.nonLinearEffects(model, data, q[i], v[i])) - g
                out["coriolis"][i] = Jbar.T @ Cv - Lambda @ (dJ[rows] @ v[i])
    return finite("operational-space", **out)


def operational_space_size(robot: Robot, options: dict[str, Any], with_v: bool) -> int:
    """Λ (k, k), J (k, nv), J̄ (nv, k), p (k) and with v μ (k); k = 6 for the "full" task,
    3 for "linear" or "angular"."""
    k = 6 if options.get("task", "full") == "full" else 3
    return k * k + 2 * k * robot.nv + k + (k if with_v else 0)


OPERATIONAL_SPACE = (
    Quantity(
        "operational-space",
        ("q",),
        operational_space,
        "Operational-space inertia Λ, dynamically consistent inverse J̄, gravity p and "
        "(with v) Coriolis μ of a frame",
        optional=("v",),
        answer_size=operational_space_size,
    ),
)
