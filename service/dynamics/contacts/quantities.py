"""Dynamics with rigid contacts: constrained forward dynamics, contact-consistent inverse
dynamics and impacts, for a contact set given per request (`service.dynamics.contacts.model`
says how contacts become constraints, their force frames and the singularity test).

With M the mass matrix (nv×nv), h = C(q, v) v + g(q), Jc the contact Jacobian (m×nv,
LOCAL_WORLD_ALIGNED rows) and λ the contact forces (m, N and N·m, world axes at each frame):

- contact-dynamics: M a + h = τ + Jcᵀ λ with Jc a + γ = 0, γ the contacts' acceleration at
  a = 0 (J̇c v plus, for point contacts, the classical term ω × v). Pinocchio's
  `constraintDynamics` (sparse Cholesky of the KKT matrix): exact, no Baumgarte correction
  here. With `damping` μ > 0: proximal iterations (A + μ I) λₖ₊₁ = μ λₖ − b from λ₀ = 0
  (A = Jc M⁻¹ Jcᵀ) until the constraint holds to a tolerance, converging to the minimum-norm
  λ of a rank-deficient set; unconverged answers are refused (`contacts.solve`).
- contact-inverse-dynamics (no Pinocchio algorithm; least squares in numpy): for a floating
  base (free-flyer, MJCF free joint or planar root, its first k = 6 or 3 rows "root"),
  r = (M a + h)_root and λ = argmin ‖λ‖ among the minimizers of ‖(Jcᵀ)_root λ − r‖ (the
  pseudo-inverse solution, `contacts.solve.root_balance`), residual = ‖(Jcᵀ)_root λ − r‖ (N
  and N·m mixed: the 2-norm of the root wrench no contact force can produce),
  τ = M a + h − Jcᵀ λ with its root rows set to 0. μ > 0 only admits a rank-deficient set
  (the least squares need no regularization). A fixed-base robot's actuators can produce
  any τ, so λ = 0 and τ = M a + h (RNEA); the contacts are only checked.
  No friction cone, no unilaterality: λ may pull on the ground (negative normal force).
- impulse-dynamics: M (v⁺ − v⁻) = Jcᵀ Λ with Jc v⁺ = −e Jc v⁻ (Pinocchio's
  `impulseDynamics`; with μ > 0 its proximal iterations continued here to the tolerance),
  Λ the impulses (N·s, N·m·s), laid out like λ.

Every quantity here has a work estimate (`contact_work`): states × the work of one
constrained evaluation (`contacts.solve.evaluation_work`: contacts, their kind, damping
iterations), refused over `max_work` before computing; a batch asks `should_stop` every few
milliseconds (`service.dynamics.stopping`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from service.dynamics.contacts.model import constraint_models, constraint_rows
from service.dynamics.contacts.solve import (
    EXACT_ACCURACY,
    check_damping,
    check_work,
    converge_impulse,
    evaluation_work,
    forward_violation,
    not_converged,
    proximal_settings,
    root_balance,
)
from service.dynamics.quantity import Quantity, Results, finite
from service.dynamics.stopping import ShouldStop, Stopper
from service.errors import InvalidInput
from service.registry.robot import Robot
from service.states import States

Contacts = Sequence[Mapping[str, Any]]


def root_rows(robot: Robot) -> int:
    """The number of unactuated root rows of v: 6 for a free-flyer root or an MJCF free
    joint, 3 for a planar one, 0 for a fixed base (`Robot.root_nv`)."""
    return robot.root_nv


def contact_work(robot: Robot, s: States, options: dict[str, Any]) -> int:
    """The work of a contact request: states × one constrained evaluation of its contacts
    (`contacts.solve.evaluation_work`; contact-inverse-dynamics adds an RNEA, nv)."""
    return int(
        s.count
        * _state_work(robot, options.get("contacts") or (), float(options.get("damping") or 0.0))
    )


def _state_work(robot: Robot, contacts: Contacts, damping: float) -> float:
    """One state of a contact quantity: a constrained evaluation (impacts iterate in Python,
    counted for all three) and an RNEA."""
    return (
        evaluation_work(robot.nv, constraint_rows(contacts), damping, python_iterations=True)
        + robot.nv
    )


def _admit(
    name: str, robot: Robot, s: States, contacts: Contacts, damping: float, max_work: int | None
) -> float:
    """Validate the options (contacts, damping) and the work; answers μ."""
    mu = check_damping(damping)
    m = constraint_rows(contacts)
    each = _state_work(robot, contacts, mu)
    check_work(
        name,
        s.count * each,
        max_work,
        f"{s.count} states × {each:,.0f} (one evaluation of m = {m} constraint rows on "
        f"nv = {robot.nv}{', damped' if mu else ''})",
        each,
        "states",
    )
    return mu


def contact_dynamics(
    robot: Robot,
    s: States,
    *,
    contacts: Contacts,
    damping: float = 0.0,
    max_work: int | None = None,
    should_stop: ShouldStop | None = None,
) -> Results:
    """Constrained forward dynamics M a + h = τ + Jcᵀ λ, Jc a + γ = 0: a (N, nv) in rad/s²
    and m/s², contact_forces λ (N, m) in N and N·m (LOCAL_WORLD_ALIGNED at each frame's
    origin, in the order of `contacts`). `SingularConfiguration` for a rank-deficient Jc
    unless `damping` μ > 0, and for damped iterations that miss the tolerance."""
    mu = _admit("contact-dynamics", robot, s, contacts, damping, max_work)
    cs = constraint_models(robot, contacts)
    q, v, tau = s["q"], s["v"], s["tau"]
    n = q.shape[0]
    a, forces = np.empty((n, robot.nv)), np.empty((n, cs.size))
    pivots = np.empty((n, cs.size))
    settings = proximal_settings(mu)
    model, models = robot.model, cs.models
    with robot.data() as data:
        datas = cs.workspace(robot, data).datas
        stop = Stopper(should_stop, "contact-dynamics", "state", total=n)
        for i in range(n):
            stop.poll(i)
            a[i] = pin.constraintDynamics(model, data, q[i], v[i], tau[i], models, datas, settings)
            forces[i] = data.lambda_c
            pivots[i] = data.constraint_chol.D[: cs.size]
            if mu:
                violation, accepted = forward_violation(data, settings)
                if not violation <= accepted and np.isfinite(a[i]).all():
                    cs.check_all(robot, pivots[i : i + 1], s.batched, mu, i)
                    raise not_converged(
                        "forces", violation, accepted, mu, i if s.batched else None, cs.names
                    )
    cs.check_all(robot, pivots, s.batched, mu)
    return finite("contact-dynamics", a=a, contact_forces=forces)


def contact_inverse_dynamics(
    robot: Robot,
    s: States,
    *,
    contacts: Contacts,
    damping: float = 0.0,
    max_work: int | None = None,
    should_stop: ShouldStop | None = None,
) -> Results:
    """τ (N, nv), zero on a floating root's rows, contact_forces λ (N, m) and residual (N,)
    such that M a + h = τ + Jcᵀ λ on the actuated rows and, on the root rows, up to the
    residual wrench no λ can produce (see the module). λ is the minimum-norm solution."""
    mu = _admit("contact-inverse-dynamics", robot, s, contacts, damping, max_work)
    cs = constraint_models(robot, contacts)
    q, v, a = s["q"], s["v"], s["a"]
    n, k = q.shape[0], root_rows(robot)
    tau, forces, residual = np.empty((n, robot.nv)), np.zeros((n, cs.size)), np.zeros(n)
    model = robot.model
    # one solve: its factorization is the singularity test (and gives Jc at q)
    settings = pin.ProximalSettings(EXACT_ACCURACY, EXACT_ACCURACY, mu, 1)
    zero = np.zeros(robot.nv)
    with robot.data() as data:
        work = cs.workspace(robot, data)
        stop = Stopper(should_stop, "contact-inverse-dynamics", "state", total=n)
        for i in range(n):
            stop.poll(i)
            rhs = np.array(pin.rnea(model, data, q[i], v[i], a[i]))
            if k == 0:
                tau[i] = rhs
                continue  # a fixed base: actuators give any τ, the contacts need not act
            # the KKT factorization gives the singularity test and Jc at q
            pin.constraintDynamics(model, data, q[i], zero, zero, cs.models, work.datas, settings)
            cs.check(robot, data, i if s.batched else None, mu)
            tau[i], forces[i], residual[i] = root_balance(rhs, work.jacobian(), k)
    return finite("contact-inverse-dynamics", tau=tau, contact_forces=forces, residual=residual)


def impulse_dynamics(
    robot: Robot,
    s: States,
    *,
    contacts: Contacts,
    restitution: float = 0.0,
    damping: float = 0.0,
    max_work: int | None = None,
    should_stop: ShouldStop | None = None,
) -> Results:
    """Rigid impact at the contacts: v (N, nv) just after, M (v⁺ − v⁻) = Jcᵀ Λ with
    Jc v⁺ = −e Jc v⁻, and contact_impulses Λ (N, m) in N·s and N·m·s, laid out like
    contact forces. With μ > 0, to the tolerance of `contacts.solve`."""
    mu = _admit("impulse-dynamics", robot, s, contacts, damping, max_work)
    e = float(restitution)
    if not 0.0 <= e <= 1.0:
        raise InvalidInput("restitution must be a number e with 0 ≤ e ≤ 1")
    cs = constraint_models(robot, contacts)
    q, v = s["q"], s["v"]
    n = q.shape[0]
    after, impulses = np.empty((n, robot.nv)), np.empty((n, cs.size))
    pivots = np.empty((n, cs.size))
    settings = proximal_settings(mu)
    with robot.data() as data:
        work = cs.workspace(robot, data)
        stop = Stopper(should_stop, "impulse-dynamics", "state", total=n)
        for i in range(n):
            stop.poll(i)
            after[i] = pin.impulseDynamics(
                robot.model, data, q[i], v[i], cs.models, work.datas, e, settings
            )
            impulses[i] = data.impulse_c
            pivots[i] = data.constraint_chol.D[: cs.size]
            if mu:
                cs.check_all(robot, pivots[i : i + 1], s.batched, mu, i)
                after[i], impulses[i], violation, accepted = converge_impulse(
                    data, v[i], after[i], mu
                )
                if not violation <= accepted:
                    raise not_converged(
                        "impulses", violation, accepted, mu, i if s.batched else None, cs.names
                    )
    cs.check_all(robot, pivots, s.batched, mu)
    return finite("impulse-dynamics", v=after, contact_impulses=impulses)


def contact_size(options: dict[str, Any]) -> int:
    """m, the numbers of a contact force vector: 3 per point contact, 6 per 6d contact."""
    return sum(3 if c.get("type", "point") == "point" else 6 for c in options.get("contacts", ()))


CONTACTS = (
    Quantity(
        "contact-dynamics",
        ("q", "v", "tau"),
        contact_dynamics,
        "Constrained forward dynamics with rigid contacts: accelerations and contact forces",
        joint_answers=("a",),
        settings=("max_work",),
        work=contact_work,
        answer_size=lambda r, o, v: r.nv + contact_size(o),
    ),
    Quantity(
        "contact-inverse-dynamics",
        ("q", "v", "a"),
        contact_inverse_dynamics,
        "Contact-consistent inverse dynamics: actuated torques and minimum-norm contact forces",
        joint_answers=("tau",),
        settings=("max_work",),
        work=contact_work,
        answer_size=lambda r, o, v: r.nv + contact_size(o) + 1,
    ),
    Quantity(
        "impulse-dynamics",
        ("q", "v"),
        impulse_dynamics,
        "Rigid impact at contacts: velocities just after and contact impulses",
        joint_answers=("v",),
        settings=("max_work",),
        work=contact_work,
        answer_size=lambda r, o, v: r.nv + contact_size(o),
    ),
)
