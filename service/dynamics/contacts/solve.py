"""The solves of the contact quantities: proximal iterations to a constraint tolerance, the
root least squares of contact-consistent inverse dynamics, and the work estimate of one
contact evaluation.

Proximal iterations (damping μ > 0). Pinocchio factors the damped KKT matrix
K = [[−μ I, Jc], [Jcᵀ, M]] and iterates from λ₀ = 0

    K [−λₖ₊₁; x] = [r + μ λₖ; f]    ⇔    (A + μ I) λₖ₊₁ = μ λₖ − b,   A = Jc M⁻¹ Jcᵀ,

with (r, f) = (the desired contact acceleration −γ, τ − h) for constrained dynamics (x = a)
and (−(1 + e) Jc v⁻, 0) for an impact (x = v⁺ − v⁻). The first block row gives the
constraint's violation after each iteration exactly:

    Jc x − r = μ (λₖ − λₖ₊₁),

so the iterations stop when ‖μ (λₖ₊₁ − λₖ)‖∞ ≤ CONSTRAINT_ACCURACY · (1 + ‖r‖∞), in m/s² and
rad/s² (constrained dynamics) or m/s and rad/s (impacts). They converge to the minimum-norm λ
of a consistent set (e.g. a foot listed twice gets half the force in each copy), at a rate
μ / (σ + μ) per iteration in each eigen-direction σ > 0 of A: quickly when μ is small against
A's nonzero eigenvalues, slowly when it is not. `constraintDynamics` iterates itself;
`impulseDynamics` (Pinocchio 4.1) does one solve whatever `max_iter` says, so the impact's
iterations are done here with the same factorization (K⁻¹ is linear: each iteration adds
K⁻¹ [μ λₖ; 0] to the first solve). An answer that does not meet the tolerance within
MAX_PROXIMAL_ITERATIONS — μ too large for this contact set, or constraints no force can
satisfy — is refused (`SingularConfiguration`) with the violation it reached; μ above
MAX_DAMPING is refused before any computation.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from service.errors import InvalidInput, SingularConfiguration

CONSTRAINT_ACCURACY = 1e-9  # relative to 1 + ‖r‖∞ (see the module)
ROLLOUT_ACCURACY = 1e-6  # the same within simulate's rollouts (see simulation.py)
MAX_PROXIMAL_ITERATIONS = 100
MAX_DAMPING = 1.0  # in the units of A: 1/kg on force rows, 1/(kg·m²) on torque rows
EXACT_ACCURACY = 1e-12  # Pinocchio's settings of the one undamped solve


def check_damping(damping: Any) -> float:
    """μ as a float, or `InvalidInput` unless 0 ≤ μ ≤ MAX_DAMPING (finite)."""
    try:
        mu = float(damping)
    except (TypeError, ValueError):
        raise InvalidInput(f"damping must be a number μ with 0 ≤ μ ≤ {MAX_DAMPING:g}") from None
    if not 0.0 <= mu <= MAX_DAMPING:  # False for NaN
        raise InvalidInput(
            f"damping must be a number μ with 0 ≤ μ ≤ {MAX_DAMPING:g} (1/kg, the units of "
            "Jc M⁻¹ Jcᵀ): it regularizes a rank-deficient contact set and must stay small "
            "against that matrix (1e-6 to 1e-8 is usual); see docs/contacts.md"
        )
    return mu


def proximal_settings(damping: float) -> Any:
    """Pinocchio's proximal settings: one exact solve without damping; with μ > 0 iterations
    until μ ‖λₖ₊₁ − λₖ‖∞ ≤ CONSTRAINT_ACCURACY (Pinocchio's relative criterion; its absolute
    one is disabled) or MAX_PROXIMAL_ITERATIONS."""
    if damping == 0.0:
        return pin.ProximalSettings(EXACT_ACCURACY, EXACT_ACCURACY, 0.0, 1)
    return pin.ProximalSettings(
        0.0, CONSTRAINT_ACCURACY / damping, damping, MAX_PROXIMAL_ITERATIONS
    )


def tolerance(r: np.ndarray, accuracy: float = CONSTRAINT_ACCURACY) -> float:
    """The largest constraint violation accepted for right-hand side r (see the module)."""
    return accuracy * (1.0 + float(np.abs(r).max(initial=0.0)))


def not_converged(
    what: str,
    violation: float,
    accepted: float,
    damping: float,
    state: int | None,
    contacts: list[str],
) -> SingularConfiguration:
    """The 422 for damped iterations that did not meet the constraint tolerance."""
    where = f"state {state}: " if state is not None else ""
    extra = {"state": state} if state is not None else {}
    return SingularConfiguration(
        f"{where}the contact {what} with damping μ = {damping:g} did not converge: after "
        f"{MAX_PROXIMAL_ITERATIONS} proximal iterations the constraint is violated by "
        f"{violation:.3g}, over the tolerance {accepted:.3g}; use a smaller damping (it must "
        "be small against Jc M⁻¹ Jcᵀ), or check that the contacts can all hold at once",
        contacts=contacts,
        residual=violation,
        **extra,
    )


def forward_violation(
    data: Any, settings: Any, accuracy: float = CONSTRAINT_ACCURACY
) -> tuple[float, float]:
    """(violation ‖Jc a − r‖∞, tolerance) of the constrained dynamics just computed in `data`
    with damped `settings` (Pinocchio's last ‖λₖ₊₁ − λₖ‖∞ times μ)."""
    return (
        settings.mu * settings.relative_residual,
        tolerance(np.asarray(data.primal_rhs_contact), accuracy),
    )


def converge_impulse(
    data: Any, v_before: np.ndarray, v_after: np.ndarray, damping: float
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Continue the proximal iterations of an impact that `impulseDynamics` solved once in
    `data` (damped factorization K there): (v⁺, Λ, violation, tolerance)."""
    chol = data.constraint_chol
    m = len(data.impulse_c)
    first = np.concatenate([-np.asarray(data.impulse_c), v_after - v_before])
    r = np.asarray(chol.matrix())[:m] @ first  # −(1 + e) Jc v⁻
    accepted = tolerance(r)
    previous, impulses = np.zeros(m), -first[:m]
    solution, zeros = first, np.zeros(len(v_before))
    violation = damping * float(np.abs(impulses).max(initial=0.0))
    for _ in range(MAX_PROXIMAL_ITERATIONS - 1):
        if violation <= accepted:
            break
        solution = first + np.asarray(chol.solve(np.concatenate([damping * impulses, zeros])))
        previous, impulses = impulses, -solution[:m]
        violation = damping * float(np.abs(impulses - previous).max(initial=0.0))
    return v_before + solution[m:], impulses, violation, accepted


def root_balance(tau: np.ndarray, Jc: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Contact-consistent torques at one state: with r = (M a + h)_root the first k rows of
    `tau` = M a + h and B = (Jcᵀ)_root, λ = argmin ‖λ‖ among the minimizers of ‖B λ − r‖
    (the pseudo-inverse solution, `numpy.linalg.lstsq`); answers (τ = M a + h − Jcᵀ λ with
    its root rows 0, λ, residual ‖B λ − r‖). The one solve of contact-inverse-dynamics and of
    simulate's contact-consistent gravity compensation. With k = 0 (a fixed base) λ = 0."""
    if k == 0:
        return tau, np.zeros(Jc.shape[0]), 0.0
    B, r = Jc[:, :k].T, tau[:k]
    lam = np.linalg.lstsq(B, r, rcond=None)[0]
    out = tau - Jc.T @ lam
    out[:k] = 0.0
    return out, lam, float(np.linalg.norm(B @ lam - r))


def evaluation_work(nv: int, m: int, damping: float, python_iterations: bool = False) -> float:
    """The work of one constrained evaluation (constrained dynamics or an impact) of m
    constraint rows, in the service's work units (one unit ≈ one joint of ABA, about 0.3 µs;
    measured on Talos and Solo-12 with 1 to 64 contacts): the recursions (nv + m nv / 8), the
    factorization of the constraint rows (m³ / 4000) and, with damping, the worst case of
    MAX_PROXIMAL_ITERATIONS solves of size m + nv ((m + nv)² / 800 each, plus 10 for
    Python's loop when the iterations are done here: `python_iterations`)."""
    work = nv + m * nv / 8.0 + m**3 / 4000.0
    if damping > 0.0:
        each = (m + nv) ** 2 / 800.0 + (10.0 if python_iterations else 1.0)
        work += MAX_PROXIMAL_ITERATIONS * each
    return work


_LARGEST = {"states": "largest_batch", "steps": "largest_steps"}


def check_work(
    quantity: str,
    work: float,
    max_work: float | None,
    factors: str,
    each: float = 0.0,
    unit: str = "states",
) -> None:
    """`InvalidInput` naming the limit when the estimated `work` is over `max_work` (None:
    no limit, as for a script), and what fits: at most max_work // `each` `unit` (the work
    of one state or step), given as the member `largest_batch` (states) or `largest_steps`
    too."""
    if max_work is not None and work > max_work:
        fits = int(max_work // each) if each > 0 else 0
        hint = (
            f"at most {fits:,} {unit} of this request fit; "
            if fits >= 1
            else f"not even one of its {unit} fits; "
        )
        raise InvalidInput(
            f"{quantity}: the estimated work of this request, {factors} = {work:,.0f} units, is "
            f"over the limit of {max_work:,} (ROBODYN_MAX_WORK; a unit is about 0.3–0.4 µs): "
            f"{hint}send fewer {unit} or contacts, or no damping",
            work=int(work),
            max_work=int(max_work),
            **{_LARGEST.get(unit, "largest"): fits},
        )
