"""Fitting the parameters θ = [π; φ] (inertial, friction) to measured torques.

The data are rows A β = b: A (n, nv, r) the regressor columns of the base parameters β = P θ
(see `base_parameters`), b (n, nv) the measured torques minus what is known (the armature
term, or a whole known robot for a payload).

- **Weighted least squares** (ordinary with `weighted` False). An ordinary least-squares pass
  gives each joint's residual standard deviation σ_j (its noise level); every row of joint j
  is then divided by σ_j and solved again (QR of the weighted A: R β = Qᵀ b_w). The
  covariance of β is s² (RᵀR)⁻¹ with s² the weighted residual variance; its diagonal's square
  roots are the standard deviations. (No joint's noise level is taken below WEIGHT_RANGE × the
  largest one, nor below NOISE_FLOOR × the RMS of the torques fitted: a noise-free log's
  residuals are rounding, and its noise level is then the torques' own scale, so the data term
  is in the same units whatever the torques' units.)
  The condition number is that of the weighted A with its columns scaled to unit norm (so it
  measures how well the motion separates the base parameters, not their units).
- **Full parameters from β.** The torques fix only β; the full θ reported is the one closest
  to the prior θ₀ (the model's own values) with P θ = β, distances scaled by `scale`:
  θ = θ₀ + S² Pᵀ (P S² Pᵀ)⁻¹ (β − P θ₀), S = diag(scale).
- **Physically consistent fit** (a semidefinite program, cvxpy with Clarabel, SCS if Clarabel
  fails): minimize ‖R P θ − Qᵀ b_w‖² + ‖(θ − θ₀) / scale‖² subject to J(π_b) ⪰ 0 for every
  body b (the pseudo-inertia of `parameters`). The first term is the weighted least-squares
  objective up to a constant (residuals in units of each joint's noise); the second is a
  Gaussian prior of standard deviation `scale` around the model's values, which fixes the
  parameters the torques do not determine and hardly moves those they do. Both terms are
  dimensionless, so the prior's weight does not depend on the torques' units: a noise-free log
  gives back its true base parameters (to about 1e-9 relative, measured on the UR5 with its
  inertias × 1 and × 1000). The standard
  deviations reported are the posterior's, (RᵀR / s² + (P S² Pᵀ)⁻¹)^(-1/2) on the diagonal: the
  data's where the log determines a base parameter, the prior's spread where it does not (a
  joint that never moves).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from service.dynamics.identification.base_parameters import BaseParameters
from service.dynamics.identification.parameters import PER_BODY
from service.errors import InvalidInput

POORLY_EXCITED = 1e8  # a condition number above this: the motion reveals too little
WEIGHT_RANGE = 1e-3  # the smallest joint noise level used, relative to the largest
NOISE_FLOOR = 1e-8  # the smallest noise level used, relative to the torques' RMS
CONSISTENCY_TOLERANCE = 1e-8  # pseudo-inertia eigenvalues ≥ −this count as ⪰ 0 (solver accuracy)
MIN_MASS_SCALE = 0.1  # kg: the prior's mass scale of light bodies
MIN_LENGTH_SCALE = 0.1  # m
FRICTION_SCALE = 100.0  # the prior's scale of friction parameters (N·m, N·m·s/rad): uninformative


@dataclass(frozen=True)
class Fit:
    theta: np.ndarray  # the full parameters θ (n,)
    beta: np.ndarray  # the base parameters P θ (r,)
    beta_std: np.ndarray  # their standard deviations (r,), from weighted least squares
    condition_number: float  # inf when the log leaves a base parameter undetermined
    joint_noise: np.ndarray  # σ_j (nv,), N·m or N: the ordinary fit's residual per joint
    # the covariance of β (r, r) whose diagonal is beta_std²: the data's, or the posterior's
    beta_covariance: np.ndarray
    # (r, k): columns spanning the functionals c of β (c·β) the log determines, the row space
    # of the weighted regressor (`determined_directions`)
    determined: np.ndarray


def prior_scale(pi0: np.ndarray, friction_count: int) -> np.ndarray:
    """The prior's standard deviation of each parameter: per body [m_s, m_s ℓ (×3),
    m_s ℓ² (×6)] with m_s = max(m, MIN_MASS_SCALE) and ℓ = max(‖c‖, MIN_LENGTH_SCALE)
    (a 100 % change of a body of that size), then FRICTION_SCALE for each friction parameter."""
    out = []
    for body in pi0.reshape(-1, PER_BODY):
        mass = max(float(body[0]), MIN_MASS_SCALE)
        length = max(
            float(np.linalg.norm(body[1:4])) / max(float(body[0]), 1e-12), MIN_LENGTH_SCALE
        )
        out.append([mass] + [mass * length] * 3 + [mass * length**2] * 6)
    return np.concatenate([np.ravel(out), np.full(friction_count, FRICTION_SCALE)])


def fit(
    A: np.ndarray,
    b: np.ndarray,
    base: BaseParameters,
    theta0: np.ndarray,
    scale: np.ndarray,
    bodies: int,
    consistent: bool,
    weighted: bool = True,
    still: str = "",
) -> Fit:
    """Fit θ (see the module docstring): A (n, nv, r), b (n, nv); θ₀ and `scale` (len(θ),);
    the first `bodies` blocks of 10 of θ are bodies (constrained when `consistent`).
    `weighted` False: ordinary least squares (every joint's rows weighted by the one pooled
    residual standard deviation, which changes no estimate, only the units of the SDP's data
    term). `still`: the joints that barely move and their ranges, named when the motion
    excites too little."""
    count, nv, r = A.shape
    flat_a, flat_b = A.reshape(-1, r), b.reshape(-1)
    ordinary = np.linalg.lstsq(flat_a, flat_b, rcond=None)[0]
    residual = (flat_b - flat_a @ ordinary).reshape(count, nv)
    dof = max(count - r / nv, 1.0)
    noise = np.sqrt((residual**2).sum(axis=0) / dof)
    if not weighted:
        noise = np.full(nv, float(np.sqrt(np.mean(noise**2))))
    level = float(np.sqrt(np.mean(flat_b**2))) if flat_b.size else 0.0
    noise = np.maximum(noise, NOISE_FLOOR * level)  # noiseless data: the torques' own scale
    top = float(noise.max())  # (0: no torque at all, equal weights)
    noise = np.maximum(noise, WEIGHT_RANGE * top) if top > 0.0 else np.ones(nv)
    weighted_a = (A / noise[np.newaxis, :, np.newaxis]).reshape(-1, r)
    weighted_b = (b / noise).reshape(-1)
    q, rr = np.linalg.qr(weighted_a)
    target = q.T @ weighted_b
    norms = np.linalg.norm(rr, axis=0)
    singular = np.linalg.svd(rr / np.where(norms > 0, norms, 1.0), compute_uv=False)
    condition = float(singular[0] / singular[-1]) if singular[-1] > 0 else float("inf")
    if not consistent and condition > POORLY_EXCITED:
        where = f"; barely moving: {still}" if still else ""
        raise InvalidInput(
            f"the logged motion does not excite every base parameter (condition number "
            f"{condition:.3g}{where}); log a richer motion (every joint moving, at varied "
            "speeds and accelerations) or use method 'physically-consistent', which falls back "
            "on the model's values where the log says nothing"
        )
    covariance_root = np.linalg.pinv(rr)
    beta_wls = covariance_root @ target
    rows = weighted_b.size
    sigma2 = float(np.sum((weighted_b - weighted_a @ beta_wls) ** 2)) / max(rows - r, 1)
    covariance = sigma2 * covariance_root @ covariance_root.T
    projection = base.projection()
    if consistent:
        # the posterior's: data and prior (where the log says little, the prior's spread)
        prior = projection @ ((scale**2)[:, np.newaxis] * projection.T)
        covariance = _posterior_covariance(rr, sigma2, prior)
        theta = _consistent(rr @ projection, target, theta0, scale, bodies)
    else:
        theta = _closest(projection, beta_wls, theta0, scale)
    return Fit(
        theta=theta,
        beta=projection @ theta,
        beta_std=np.sqrt(np.clip(np.diag(covariance), 0.0, None)),
        condition_number=condition,
        joint_noise=noise,
        beta_covariance=covariance,
        determined=determined_directions(rr),
    )


def determined_directions(rr: np.ndarray) -> np.ndarray:
    """(r, k) columns spanning the functionals c of β that the rows R β = Qᵀ b determine: the
    row space of R, c = D V_k y with D the columns' norms and V_k the right singular vectors
    of R D⁻¹ (unit columns, as the condition number) whose singular values are above the
    largest / POORLY_EXCITED (a direction below is one the log does not excite)."""
    norms = np.linalg.norm(rr, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    _, singular, vt = np.linalg.svd(rr / norms)
    top = float(singular[0]) if singular.size else 0.0
    keep = vt[: singular.size][singular > top / POORLY_EXCITED] if top > 0 else vt[:0]
    return np.asarray(norms[:, np.newaxis] * keep.T)


def _posterior_covariance(rr: np.ndarray, sigma2: float, prior: np.ndarray) -> np.ndarray:
    """C = (RᵀR / s² + Π⁻¹)⁻¹ (Π the prior's covariance of β), computed without inverting the
    information matrix, which loses all precision (or is singular) when the residual s² is
    tiny and some directions are not excited: with Π = L Lᵀ and R L = U Σ Vᵀ,
    C = L V diag(s² / (s² + σ_k²)) Vᵀ Lᵀ, each weight in [0, 1] (1: a direction the log does
    not see keeps the prior's spread; 0: a noiseless one)."""
    eigenvalues, vectors = np.linalg.eigh(prior)
    root = vectors * np.sqrt(np.clip(eigenvalues, 0.0, None))
    _, singular, vt = np.linalg.svd(rr @ root)
    singular = np.concatenate([singular, np.zeros(vt.shape[0] - singular.size)])
    total = sigma2 + singular**2
    weights = np.divide(sigma2, total, out=np.ones_like(total), where=total > 0)
    spread = root @ vt.T
    return np.asarray((spread * weights) @ spread.T)


def _closest(
    projection: np.ndarray, beta: np.ndarray, theta0: np.ndarray, scale: np.ndarray
) -> np.ndarray:
    """θ closest to θ₀ (scaled) with P θ = β."""
    s2p = (scale**2)[:, np.newaxis] * projection.T
    step = scipy.linalg.lstsq(projection @ s2p, beta - projection @ theta0)[0]
    return np.asarray(theta0 + s2p @ step)


def pseudo_inertia_map() -> np.ndarray:
    """L (16, 10): vec(J(π)) = L π, row-major 4×4 (see `parameters.pseudo_inertia`)."""
    out = np.zeros((16, PER_BODY))
    trace = {4: 1.0, 6: 1.0, 9: 1.0}  # Ixx, Iyy, Izz
    inertia_index = {(0, 0): 4, (0, 1): 5, (1, 1): 6, (0, 2): 7, (1, 2): 8, (2, 2): 9}
    for i in range(3):
        for j in range(3):
            k = inertia_index[(min(i, j), max(i, j))]
            out[4 * i + j, k] -= 1.0
            if i == j:
                for t, c in trace.items():
                    out[4 * i + j, t] += 0.5 * c
        out[4 * i + 3, 1 + i] = out[12 + i, 1 + i] = 1.0
    out[15, 0] = 1.0
    return out


def _consistent(
    data_map: np.ndarray, target: np.ndarray, theta0: np.ndarray, scale: np.ndarray, bodies: int
) -> np.ndarray:
    """The semidefinite program of the module docstring, in the scaled step
    δ = (θ − θ₀) / scale."""
    import cvxpy as cp  # (seconds to import: only when a consistent fit is asked for)

    step = cp.Variable(theta0.size)
    theta = theta0 + cp.multiply(scale, step)
    lmap = pseudo_inertia_map()
    constraints = []
    for body in range(bodies):
        block = theta[PER_BODY * body : PER_BODY * (body + 1)]
        pseudo = cp.Variable((4, 4), PSD=True)
        constraints.append(cp.vec(pseudo, order="C") == lmap @ block)
    residual = data_map @ theta - target
    problem = cp.Problem(cp.Minimize(cp.sum_squares(residual) + cp.sum_squares(step)), constraints)
    for solver in (cp.CLARABEL, cp.SCS):
        try:
            problem.solve(solver=solver)
        except (cp.SolverError, ValueError, ArithmeticError):  # (SCS: "allocation error")
            continue
        if problem.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) and step.value is not None:
            return np.asarray(theta0 + scale * step.value)
    raise InvalidInput(
        "the physically consistent fit did not converge for this log (the "
        f"solver ended with status '{problem.status}'); method "
        "'least-squares' gives the unconstrained fit"
    )
