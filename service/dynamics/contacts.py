"""Dynamics with rigid contacts: constrained forward dynamics, contact-consistent inverse
dynamics and impacts, for a contact set given per request (`service.dynamics.contacts_model`
says how contacts become constraints, their force frames and the singularity test).

With M the mass matrix (nv×nv), h = C(q, v) v + g(q), Jc the contact Jacobian (m×nv,
LOCAL_WORLD_ALIGNED rows) and λ the contact forces (m, N and N·m, world axes at each frame):

- contact-dynamics: M a + h = τ + Jcᵀ λ with Jc a + γ = 0, γ the contacts' acceleration at
  a = 0 (J̇c v plus, for point contacts, the classical term ω × v). Pinocchio's
  `constraintDynamics` (sparse Cholesky of the KKT matrix): exact, no Baumgarte correction
  here. With `damping` μ > 0: its proximal algorithm, iterating (A + μ I) λₖ₊₁ = μ λₖ − b from
  λ₀ = 0 (A = Jc M⁻¹ Jcᵀ), which converges to the minimum-norm λ of a rank-deficient set.
- contact-inverse-dynamics (no Pinocchio algorithm; least squares in numpy): for a floating
  base (free-flyer or planar root, its first k = 6 or 3 rows "root"), r = (M a + h)_root and
  λ = argmin ‖λ‖ among the minimizers of ‖(Jcᵀ)_root λ − r‖ (the pseudo-inverse solution,
  `numpy.linalg.lstsq`), residual = ‖(Jcᵀ)_root λ − r‖ (N and N·m mixed: the 2-norm of the
  root wrench no contact force can produce), τ = M a + h − Jcᵀ λ with its root rows set to 0.
  With μ > 0: λ = argmin ‖(Jcᵀ)_root λ − r‖² + μ ‖λ‖². A fixed-base robot's actuators
  can produce any τ, so λ = 0 and τ = M a + h (RNEA); the contacts are only checked.
  No friction cone, no unilaterality: λ may pull on the ground (negative normal force).
- impulse-dynamics: M (v⁺ − v⁻) = Jcᵀ Λ with Jc v⁺ = −e Jc v⁻ (Pinocchio's
  `impulseDynamics`), Λ the impulses (N·s, N·m·s), laid out like λ.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from service.dynamics.contacts_model import ContactWorkspace, constraint_models
from service.dynamics.quantity import Quantity, Results, finite
from service.registry.robot import Robot, joint_type
from service.states import States

Contacts = Sequence[Mapping[str, Any]]


def root_rows(robot: Robot) -> int:
    """The number of unactuated root rows of v: 6 for a free-flyer root, 3 for a planar one
    (the model's first joint, on the world: a catalog robot's or an upload's `root_joint`,
    or an MJCF free joint), 0 for a fixed base."""
    model = robot.model
    if model.njoints > 1 and model.parents[1] == 0 and joint_type(model.joints[1]) in (
            "free_flyer", "planar"):
        return int(model.joints[1].nv)
    return 0


def contact_dynamics(robot: Robot, s: States, *, contacts: Contacts,
                     damping: float = 0.0) -> Results:
    """Constrained forward dynamics M a + h = τ + Jcᵀ λ, Jc a + γ = 0: a (N, nv) in rad/s²
    and m/s², contact_forces λ (N, m) in N and N·m (LOCAL_WORLD_ALIGNED at each frame's
    origin, in the order of `contacts`). `SingularConfiguration` for a rank-deficient Jc
    unless `damping` μ > 0."""
    cs = constraint_models(robot, contacts)
    q, v, tau = s["q"], s["v"], s["tau"]
    n = q.shape[0]
    a, forces = np.empty((n, robot.nv)), np.empty((n, cs.size))
    pivots = np.empty((n, cs.size))
    settings = ContactWorkspace.settings(damping)
    model, models = robot.model, cs.models
    with robot.data() as data:
        datas = cs.workspace(robot, data).datas
        for i in range(n):
            a[i] = pin.constraintDynamics(model, data, q[i], v[i], tau[i], models, datas,
                                          settings)
            forces[i] = data.lambda_c
            pivots[i] = data.constraint_chol.D[: cs.size]
    cs.check_all(robot, pivots, s.batched, damping)
    return finite("contact-dynamics", a=a, contact_forces=forces)


def _root_forces(B: np.ndarray, r: np.ndarray, damping: float) -> tuple[np.ndarray, float]:
    """λ and the residual ‖B λ − r‖ with B = (Jcᵀ)_root (k×m): minimum-norm least squares,
    or with μ > 0 the ridge solution (Bᵀ B + μ I)⁻¹ Bᵀ r."""
    if damping > 0.0:
        lam = np.linalg.solve(B.T @ B + damping * np.eye(B.shape[1]), B.T @ r)
    else:
        lam = np.linalg.lstsq(B, r, rcond=None)[0]
    return lam, float(np.linalg.norm(B @ lam - r))


def contact_inverse_dynamics(robot: Robot, s: States, *, contacts: Contacts,
                             damping: float = 0.0) -> Results:
    """τ (N, nv), zero on a floating root's rows, contact_forces λ (N, m) and residual (N,)
    such that M a + h = τ + Jcᵀ λ on the actuated rows and, on the root rows, up to the
    residual wrench no λ can produce (see the module). λ is the minimum-norm solution."""
    cs = constraint_models(robot, contacts)
    q, v, a = s["q"], s["v"], s["a"]
    n, k = q.shape[0], root_rows(robot)
    tau, forces, residual = np.empty((n, robot.nv)), np.zeros((n, cs.size)), np.zeros(n)
    model = robot.model
    settings = ContactWorkspace.settings(damping)
    zero = np.zeros(robot.nv)
    with robot.data() as data:
        work = cs.workspace(robot, data)
        for i in range(n):
            tau[i] = pin.rnea(model, data, q[i], v[i], a[i])
            if k == 0:
                continue  # a fixed base: actuators give any τ, the contacts need not act
            rhs = tau[i].copy()
            # the KKT factorization gives the singularity test and Jc at q
            pin.constraintDynamics(model, data, q[i], zero, zero, cs.models, work.datas,
                                   settings)
            cs.check(robot, data, i if s.batched else None, damping)
            Jc = work.jacobian()
            forces[i], residual[i] = _root_forces(Jc[:, :k].T, rhs[:k], damping)
            tau[i] = rhs - Jc.T @ forces[i]
            tau[i, :k] = 0.0
    return finite("contact-inverse-dynamics", tau=tau, contact_forces=forces,
                  residual=residual)


def impulse_dynamics(robot: Robot, s: States, *, contacts: Contacts, restitution: float = 0.0,
                     damping: float = 0.0) -> Results:
    """Rigid impact at the contacts: v (N, nv) just after, M (v⁺ − v⁻) = Jcᵀ Λ with
    Jc v⁺ = −e Jc v⁻, and contact_impulses Λ (N, m) in N·s and N·m·s, laid out like
    contact forces."""
    cs = constraint_models(robot, contacts)
    q, v = s["q"], s["v"]
    n = q.shape[0]
    after, impulses = np.empty((n, robot.nv)), np.empty((n, cs.size))
    pivots = np.empty((n, cs.size))
    settings = ContactWorkspace.settings(damping)
    with robot.data() as data:
        work = cs.workspace(robot, data)
        for i in range(n):
            after[i] = pin.impulseDynamics(robot.model, data, q[i], v[i], cs.models,
                                           work.datas, restitution, settings)
            impulses[i] = data.impulse_c
            pivots[i] = data.constraint_chol.D[: cs.size]
    cs.check_all(robot, pivots, s.batched, damping)
    return finite("impulse-dynamics", v=after, contact_impulses=impulses)


def contact_size(options: dict[str, Any]) -> int:
    """m, the numbers of a contact force vector: 3 per point contact, 6 per 6d contact."""
    return sum(3 if c.get("type", "point") == "point" else 6 for c in options.get("contacts", ()))


CONTACTS = (
    Quantity("contact-dynamics", ("q", "v", "tau"), contact_dynamics,
             "Constrained forward dynamics with rigid contacts: accelerations and contact "
             "forces", joint_answers=("a",),
             answer_size=lambda r, o, v: r.nv + contact_size(o)),
    Quantity("contact-inverse-dynamics", ("q", "v", "a"), contact_inverse_dynamics,
             "Contact-consistent inverse dynamics: actuated torques and minimum-norm contact "
             "forces", joint_answers=("tau",),
             answer_size=lambda r, o, v: r.nv + contact_size(o) + 1),
    Quantity("impulse-dynamics", ("q", "v"), impulse_dynamics,
             "Rigid impact at contacts: velocities just after and contact impulses",
             joint_answers=("v",), answer_size=lambda r, o, v: r.nv + contact_size(o)),
)
