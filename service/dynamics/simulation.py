"""Forward simulation: integrate M(q) a + C(q, v) v + g(q) = τ from (q, v) for `steps` of `dt`.

The acceleration is forward dynamics (ABA, as the forward-dynamics endpoint: no joint damping,
friction or limits), under one torque source:
- no `tau` and no `controller`: τ = 0 (the robot moves under gravity alone);
- `tau` of nv numbers: constant τ; `tau` of [steps][nv]: τ_k held during step k;
- `controller` {"type": "pd", "kp", "kd", "q_target", "gravity_compensation"}: at every
  evaluation τ = kp ⊙ (q_target ⊖ q) − kd ⊙ v (+ g(q) with gravity compensation), where
  q_target ⊖ q = `pin.difference(q, q_target)` is the tangent vector from q to the target (on the
  manifold: a free-flyer's or continuous joint's error is a rotation, not a difference of
  coordinates); kp (N·m/rad) and kd (N·m·s/rad) are scalars or nv-vectors.

Integrators (q always moves on the configuration manifold, q ⊕ δ = `pin.integrate`, and unit
quaternions and (cos, sin) pairs are renormalized after each step):
- "semi-implicit-euler" (default): v ← v + dt a(q, v), then q ← q ⊕ dt v;
- "rk4": the classical 4-stage Runge–Kutta scheme in its Lie-group form
  (Runge–Kutta–Munthe-Kaas): stages at q ⊕ θᵢ, with the stage velocities mapped to the tangent
  space at q by the inverse right Jacobian of ⊕, so it is 4th order for free-flyer bases too;
  for revolute and prismatic joints it is exactly classical RK4.

The answer is the trajectory, steps + 1 samples including the initial state: t (s), q, v, and
the mechanical energy T + U (J), T = ½ vᵀ M v (with the armature) and U the gravity potential.
A batch of initial states gives one trajectory per state (same torques or controller).

With `contacts` (a fixed contact set) the acceleration is constrained forward dynamics with
Baumgarte-stabilised contacts, a PD controller acts on the actuated joints only and its gravity
compensation is contact-consistent; the answer adds `constraint_drift` (m). All of it lives in
`service.dynamics.contacts.simulation`.

Cost: states × steps × nv × stages (at most `max_simulation_work`), and with contacts
states × steps × stages × the work of one constrained evaluation (contacts, their kind,
damping iterations, the controller's compensation; at most `max_work`), both checked before
anything is computed. A long rollout can be stopped: `should_stop()` is asked every few
milliseconds of computing (`service.dynamics.stopping`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from service.dynamics.contacts.simulation import (
    ContactRollout,
    pd_with_contacts,
    rollout_evaluation_work,
)
from service.dynamics.contacts.solve import check_work
from service.dynamics.lagrangian import mechanical_energy
from service.dynamics.quantity import Quantity, Results, finite
from service.dynamics.stopping import ShouldStop, Stopper
from service.errors import DimensionMismatch, InvalidInput, NonFiniteResult
from service.registry.robot import Robot
from service.states import States, as_array, configurations

STAGES = {"semi-implicit-euler": 1, "rk4": 4}

Torque = Callable[[int, np.ndarray, np.ndarray, Any], np.ndarray]
Acceleration = Callable[..., np.ndarray]  # (robot, q, v, tau, data) -> a


def _vector(robot: Robot, field: str, value: Any, dim: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (getattr(robot, dim),):
        raise DimensionMismatch(
            f"{field} has shape {list(arr.shape)}; robot '{robot.id}' "
            f"needs {dim} = {getattr(robot, dim)} numbers"
        )
    return arr


def _gain(robot: Robot, field: str, value: Any) -> np.ndarray | float:
    if isinstance(value, float | int):
        return float(value)
    return _vector(robot, field, value, "nv")


def torque_source(
    robot: Robot, steps: int, tau: Any, controller: Mapping[str, Any] | None
) -> Torque:
    """τ(k, q, v, data) for step k at state (q, v); `data` is a borrowed pin.Data."""
    model = robot.model
    if tau is not None and controller is not None:
        raise InvalidInput(
            "give either tau (constant or scheduled torques) or a controller, not both"
        )
    if controller is not None:
        target = _vector(robot, "controller.q_target", controller["q_target"], "nq")
        target = configurations(robot, target[np.newaxis])[0]  # checked, Pinocchio's order
        kp = _gain(robot, "controller.kp", controller["kp"])
        kd = _gain(robot, "controller.kd", controller["kd"])
        compensate = bool(controller.get("gravity_compensation", False))

        def pd(k: int, q: np.ndarray, v: np.ndarray, data: Any) -> np.ndarray:
            out = kp * pin.difference(model, q, target) - kd * v
            if compensate:
                out = out + pin.computeGeneralizedGravity(model, data, q)
            return np.asarray(out)

        return pd
    if tau is None:
        zero = np.zeros(robot.nv)
        return lambda k, q, v, data: zero
    schedule = as_array("tau", tau, "(a constant torque) or 2-D (a schedule [steps][nv])")
    if schedule.ndim == 1:
        constant = _vector(robot, "tau", schedule, "nv")
        return lambda k, q, v, data: constant
    if schedule.shape != (steps, robot.nv):
        raise DimensionMismatch(
            f"tau has shape {list(schedule.shape)}; a torque schedule is "
            f"[steps][nv] = [{steps}][{robot.nv}] (or give nv numbers for "
            "a constant torque)"
        )
    return lambda k, q, v, data: schedule[k]


def check_limits(
    robot: Robot, s: States, steps: int, integrator: str, max_steps: int, max_work: int
) -> None:
    if s.count * steps > max_steps:
        total = (
            f"{s.count} states × {steps} steps = {s.count * steps}"
            if s.batched
            else (f"steps = {steps}")
        )
        raise InvalidInput(
            f"{total} is over the limit of {max_steps} simulated steps per "
            "request (ROBODYN_MAX_SIMULATION_STEPS)"
        )
    work = s.count * steps * robot.nv * STAGES[integrator]
    if work > max_work:
        fits = max_work // max(s.count * robot.nv * STAGES[integrator], 1)
        raise InvalidInput(
            f"this simulation's work, states × steps × nv × stages = {s.count} × {steps} × "
            f"{robot.nv} × {STAGES[integrator]} = {work}, is over the limit of {max_work} "
            f"(ROBODYN_MAX_SIMULATION_WORK): at most {fits:,} steps of this request fit; "
            "simulate fewer steps or states",
            work=work,
            max_work=max_work,
            largest_steps=fits,
        )


def simulation_work(robot: Robot, s: States, options: dict[str, Any]) -> int:
    """Cost estimate: states × steps × stages of the integrator × the work of one evaluation
    (nv for ABA; with contacts `contacts.simulation.rollout_evaluation_work`)."""
    stages = STAGES.get(options.get("integrator", "semi-implicit-euler"), 4)
    each: float = robot.nv
    if options.get("contacts") is not None:
        each = rollout_evaluation_work(
            robot,
            options["contacts"],
            float(options.get("damping") or 0.0),
            options.get("controller") is not None,
        )
    return int(s.count * int(options.get("steps", 1)) * stages * each)


def simulate(
    robot: Robot,
    s: States,
    *,
    dt: float,
    steps: int,
    tau: Any = None,
    controller: Mapping[str, Any] | None = None,
    max_simulation_steps: int,
    max_simulation_work: int,
    integrator: str = "semi-implicit-euler",
    contacts: Sequence[Mapping[str, Any]] | None = None,
    damping: float = 0.0,
    max_work: int | None = None,
    should_stop: ShouldStop | None = None,
) -> Results:
    """The trajectory from (q, v) over `steps` steps of `dt` s: t (N, steps+1) in s, q
    (N, steps+1, nq), v (N, steps+1, nv) and mechanical_energy (N, steps+1) in J; with
    `contacts` (a fixed contact set, `service.dynamics.contacts.simulation`) also
    constraint_drift (N, steps+1) in m. `should_stop()` (optional) is asked every few ms;
    true stops the rollout with `ComputationStopped`."""
    # max_simulation_steps and max_simulation_work: the service's settings of those names;
    # tau and the controller's gains and target are arrays (the API converts name-keyed ones)
    check_limits(robot, s, steps, integrator, max_simulation_steps, max_simulation_work)
    if contacts is not None:
        options = {
            "steps": steps,
            "integrator": integrator,
            "contacts": contacts,
            "damping": damping,
            "controller": controller,
        }
        each = rollout_evaluation_work(robot, contacts, damping, controller is not None)
        check_work(
            "simulate",
            simulation_work(robot, s, options),
            max_work,
            f"states × steps × stages × one constrained evaluation = {s.count} × "
            f"{steps} × {STAGES[integrator]} × {each:,.0f}",
            s.count * STAGES[integrator] * each,
            "steps",
        )
    stop = Stopper(should_stop, "simulate", "step", total=s.count * steps)
    # contacts: the PD's gravity compensation is replaced by a contact-consistent one
    contact = ContactRollout(robot, contacts, dt, damping) if contacts is not None else None
    plain_controller = (
        controller
        if contact is None or controller is None
        else {**controller, "gravity_compensation": False}
    )
    torque = torque_source(robot, steps, tau, plain_controller)
    accel: Acceleration = _aba
    if contact is not None:
        accel = contact.acceleration
        if controller is not None:
            torque = pd_with_contacts(
                contact, torque, bool(controller.get("gravity_compensation", False))
            )
    n = s.count
    qs, vs = np.empty((n, steps + 1, robot.nq)), np.empty((n, steps + 1, robot.nv))
    energy = np.empty((n, steps + 1))
    drift = np.empty((n, steps + 1)) if contact is not None else None
    rollout = _rk4 if integrator == "rk4" else _semi_implicit_euler
    # A diverging state overflows on its way to inf or NaN: the rollout finds it at that step
    # and answers `non_finite_result` (`_diverged`), NumPy's warning would say nothing more.
    with robot.data() as data, np.errstate(over="ignore", invalid="ignore"):
        for i in range(n):
            where = f"state {i}: " if s.batched else ""
            if contact is not None:
                contact.start(data, s["q"][i], i if s.batched else None)
            stop.where, stop.offset = where, i * steps
            rollout(
                robot,
                data,
                torque,
                dt,
                s["q"][i],
                s["v"][i],
                qs[i],
                vs[i],
                energy[i],
                where,
                accel,
                stop,
            )
            if contact is not None and drift is not None:
                drift[i] = contact.drift(qs[i], data)
    t = np.broadcast_to(dt * np.arange(steps + 1), (n, steps + 1)).copy()
    if drift is not None:
        return finite("simulate", t=t, q=qs, v=vs, mechanical_energy=energy, constraint_drift=drift)
    return finite("simulate", t=t, q=qs, v=vs, mechanical_energy=energy)


def _aba(robot: Robot, q: np.ndarray, v: np.ndarray, tau: np.ndarray, data: Any) -> np.ndarray:
    """Unconstrained forward dynamics (ABA)."""
    return np.asarray(pin.aba(robot.model, data, q, v, tau, pin.Convention.WORLD))


def _mechanical_energy(robot: Robot, data: Any, q: np.ndarray, v: np.ndarray) -> float:
    """T + U with T = ½ vᵀ M v (armature included, as in M: `lagrangian.mechanical_energy`) and
    U the potential energy of gravity."""
    return sum(mechanical_energy(robot, data, q, v))


def _diverged(where: str, k: int, dt: float) -> NonFiniteResult:
    return NonFiniteResult(
        f"simulate: {where}the state is not finite after step {k + 1} "
        f"(t = {(k + 1) * dt:.6g} s); the simulation diverged — try a "
        "smaller dt, smaller gains or the rk4 integrator"
    )


def _semi_implicit_euler(
    robot: Robot,
    data: Any,
    torque: Torque,
    dt: float,
    q: np.ndarray,
    v: np.ndarray,
    qs: np.ndarray,
    vs: np.ndarray,
    energy: np.ndarray,
    where: str,
    accel: Acceleration = _aba,
    stop: Stopper | None = None,
) -> None:
    model, normalize = robot.model, bool(robot.unit_joints)
    stop = stop or Stopper(None, "simulate", "step")
    qs[0], vs[0], energy[0] = q, v, _mechanical_energy(robot, data, q, v)
    for k in range(qs.shape[0] - 1):
        stop.poll(k)
        a = accel(robot, q, v, torque(k, q, v, data), data)
        v = v + dt * a
        q = pin.integrate(model, q, dt * v)
        if normalize:
            q = pin.normalize(model, q)
        if not np.isfinite(v).all():
            raise _diverged(where, k, dt)
        qs[k + 1], vs[k + 1] = q, v
        energy[k + 1] = _mechanical_energy(robot, data, q, v)


def _rk4(
    robot: Robot,
    data: Any,
    torque: Torque,
    dt: float,
    q: np.ndarray,
    v: np.ndarray,
    qs: np.ndarray,
    vs: np.ndarray,
    energy: np.ndarray,
    where: str,
    accel: Acceleration = _aba,
    stop: Stopper | None = None,
) -> None:
    """Runge–Kutta–Munthe-Kaas RK4: stage configurations q ⊕ θ, and q's stage slopes are the
    velocities mapped to the tangent space at q by the inverse right Jacobian of ⊕,
    dθ/dt = Jr(θ)⁻¹ v = ∂ difference(q, q ⊕ θ) / ∂(q ⊕ θ) · v (the identity for
    vector-space joints, where this is classical RK4)."""
    model = robot.model
    lie = bool(robot.unit_joints)  # any joint whose configuration space is not a vector space
    arg1 = pin.ArgumentPosition.ARG1

    def stage(k: int, theta: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(slope of θ, acceleration) at the stage configuration q ⊕ θ and velocity v."""
        at = pin.integrate(model, q, theta)
        a = np.array(accel(robot, at, v, torque(k, at, v, data), data))
        return (pin.dDifference(model, q, at, arg1) @ v if lie else v), a

    half = 0.5 * dt
    stop = stop or Stopper(None, "simulate", "step")
    qs[0], vs[0], energy[0] = q, v, _mechanical_energy(robot, data, q, v)
    for k in range(qs.shape[0] - 1):
        stop.poll(k)
        a1 = np.array(accel(robot, q, v, torque(k, q, v, data), data))
        v2 = v + half * a1
        t2, a2 = stage(k, half * v, v2)
        v3 = v + half * a2
        t3, a3 = stage(k, half * t2, v3)
        v4 = v + dt * a3
        t4, a4 = stage(k, dt * t3, v4)
        q = pin.integrate(model, q, (dt / 6.0) * (v + 2.0 * t2 + 2.0 * t3 + t4))
        v = v + (dt / 6.0) * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        if lie:
            q = pin.normalize(model, q)
        if not np.isfinite(v).all():
            raise _diverged(where, k, dt)
        qs[k + 1], vs[k + 1] = q, v
        energy[k + 1] = _mechanical_energy(robot, data, q, v)


def simulation_size(robot: Robot, options: dict[str, Any], with_v: bool) -> int:
    """t, q, v and the energy at each of the steps + 1 samples, and the drift with contacts."""
    drift = 1 if options.get("contacts") else 0
    return (int(options.get("steps", 1)) + 1) * (robot.nq + robot.nv + 2 + drift)


def fewer_steps(robot: Robot, numbers: int) -> str:
    """How many steps fit in an answer of `numbers` numbers."""
    steps = numbers // (robot.nq + robot.nv + 2) - 1
    return f"simulate at most {max(steps, 0):,} steps per request"


SIMULATION = (
    Quantity(
        "simulate",
        ("q", "v"),
        simulate,
        "Simulate: integrate forward dynamics from (q, v) under torques or a PD controller",
        joint_answers=("q", "v"),
        settings=("max_simulation_steps", "max_simulation_work", "max_work"),
        work=simulation_work,
        answer_size=simulation_size,
        smaller_request=fewer_steps,
        named_options=(
            ("tau", "nv"),
            ("controller.q_target", "nq"),
            ("controller.kp", "nv"),
            ("controller.kd", "nv"),
        ),
    ),
)
