"""The equations of motion in explicit form, M(q) q̈ + C(q, q̇) q̇ + g(q) = τ, derived
symbolically from a fixed-base model with at most six revolute or prismatic joints, with the
model's numbers (form "numeric") or linear in its base inertial parameters ("parametric").

From M(q) and U(q) (`derivation`, exact decimals; `sampled` and `parametric` for the
parametric form, exact to double precision), exactly:

- g(q) = ∂U/∂q, (nv,), in N·m (revolute) or N (prismatic);
- the Christoffel symbols of the first kind c_ijk = ½ (∂M_ij/∂q_k + ∂M_ik/∂q_j − ∂M_jk/∂q_i),
  (nv, nv, nv), symmetric in j and k;
- C_ij(q, q̇) = Σ_k c_ijk q̇_k, (nv, nv): with it Ṁ = C + Cᵀ (so Ṁ − 2C is skew-symmetric) and C
  is the matrix Pinocchio's computeCoriolisMatrix gives;
- T(q, q̇) = ½ q̇ᵀ M q̇ (J, armature included) and U(q) (J, zero at the world origin).

Simplification: none beyond the canonical form of `Series` (a finite Fourier series in the
revolute angles times monomials, exact sums of angles, equal expressions written identically),
and one documented cut: terms of M and U whose coefficient is at most `NOISE` = 1e-14 times the
largest coefficient of the same quantity are dropped as float noise (a model number such as an
inertia rotated by Pinocchio in double precision carries off-diagonal residues of ~1e-19; no such
term can change a double-precision value of the quantity; what they sum to is kept in
`ExplicitEquations.noise`, for the accuracy bound). Everything else — g, c_ijk, C, T — is
derived from the kept terms, so the identities above hold exactly between the expressions.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from decimal import Decimal, localcontext
from typing import Any

from service.dynamics.equations import parametric, sampled
from service.dynamics.equations.derivation import deadline_check, mass_matrix_and_potential
from service.dynamics.equations.model_numbers import Joint, gravity, moving_joints
from service.dynamics.equations.parametric import BaseParameter
from service.dynamics.equations.series import HALF, PRECISION, Series
from service.errors import InvalidInput

NOISE = Decimal("1e-14")
# M and U are kept to this many significant digits (23 beyond double precision). Their
# coefficients then span at most 14 orders of magnitude (NOISE), so the sums, halvings and
# integer multiples that give g, c_ijk, C and T fit in `PRECISION` = 60 digits: they are exact,
# and so are the identities Ṁ = C + Cᵀ and g = ∂U/∂q between the expressions.
KEPT_DIGITS = 40
FORMS = ("numeric", "parametric")


@dataclass(frozen=True)
class ExplicitEquations:
    """The equations of motion of one robot in explicit form, as exact series; `joints` in the
    order of q (coordinates q1 … qn)."""

    joints: list[str]
    kinds: list[str]  # "revolute" or "prismatic", per coordinate
    mass_matrix: list[list[Series]]
    gravity: list[Series]
    christoffel: list[list[list[Series]]]  # [i][j][k] = c_ijk
    coriolis_matrix: list[list[Series]]
    kinetic_energy: Series
    potential_energy: Series
    seconds: float  # how long the derivation took
    # per coordinate, the largest |q| the accuracy bound counts: 1 for a revolute one (its
    # terms are bounded by 1 whatever q), the larger magnitude of a prismatic one's limits
    reach: list[float] = field(default_factory=list)
    # the parametric form's p1 … pr (empty in the numeric form)
    parameters: list[BaseParameter] = field(default_factory=list)
    # per quantity, a bound over every q (and ‖q̇‖∞ ≤ 1) of what the noise cut changed
    noise: dict[str, float] = field(default_factory=dict)


def _without_noise(entries: list[Series]) -> tuple[list[Series], float]:
    """The entries less their noise (see the module docstring), and the largest sum of the
    |coefficients| one entry lost."""
    scale = max((s.largest_coefficient() for s in entries), default=Decimal(0))
    bound = scale * NOISE
    lost = max(
        (float(sum(abs(c) for c in s.terms.values() if abs(c) <= bound)) for s in entries),
        default=0.0,
    )
    return [s.without_terms_below(bound).rounded(KEPT_DIGITS) for s in entries], lost


def reach(model: Any, joints: list[Joint]) -> list[float]:
    """Per coordinate, the bound of |q| the accuracy counts (see `ExplicitEquations`): 1 for a
    revolute joint, and for a prismatic one the larger magnitude of its finite position
    limits (1 m when it has none: the bound is then per unit of max(1 m, |q|)^degree)."""
    out = []
    for i, joint in enumerate(joints):
        lo, hi = float(model.lowerPositionLimit[i]), float(model.upperPositionLimit[i])
        bounded = joint.kind == "prismatic" and math.isfinite(lo) and math.isfinite(hi)
        out.append(max(1.0, abs(lo), abs(hi)) if bounded else 1.0)
    return out


def derive_equations(
    model: Any,
    time_limit_s: float | None = None,
    form: str = "numeric",
    uncertainty: Mapping[str, Any] | None = None,
) -> ExplicitEquations:
    """The equations of motion of a Pinocchio `model` in explicit form (see the module
    docstring), with the model's numbers (`form` "numeric") or linear in its base inertial
    parameters ("parametric", `parametric`; with identification's `uncertainty` of a robot
    it made, each parameter's standard deviation). Raises `UnsupportedModel` for a model out
    of scope, or when the derivation takes longer than `time_limit_s` seconds (checked
    between steps)."""
    if form not in FORMS:
        raise InvalidInput(f"form must be one of {', '.join(repr(f) for f in FORMS)}")
    start = time.monotonic()
    check = deadline_check(None if time_limit_s is None else start + time_limit_s, time_limit_s)
    joints = moving_joints(model)
    n = len(joints)
    parameters: list[BaseParameter] = []
    with localcontext(prec=PRECISION):
        if form == "parametric":
            sym = parametric.symbols(model, joints)
            M, U, heads, sampled_lost = sampled.mass_matrix_and_potential(
                model, joints, sym.base.independent, sym.armature(joints)
            )
        else:
            M, U = mass_matrix_and_potential(joints, gravity(model), check)
        lost_m = lost_u = 0.0
        if form == "numeric":  # (the parametric form's: where they are sampled and rewritten)
            flat, lost_m = _without_noise([M[i][j] for i in range(n) for j in range(n)])
            M = [flat[i * n : (i + 1) * n] for i in range(n)]
            (U,), lost_u = _without_noise([U])
        if form == "parametric":
            check()
            M, U, parameters, rewritten_lost = parametric.in_base_parameters(
                sym, M, U, heads, uncertainty
            )
            # what the sampling's and the rewriting's cuts and the values as shown change
            lost_m = sampled_lost[0] + rewritten_lost[0]
            lost_u = sampled_lost[1] + rewritten_lost[1]
        g = [U.derivative(i) for i in range(n)]
        check()
        # dM[k][i][j] = ∂M_ij/∂q_k, from the upper triangle
        dM = [[[Series(n)] * n for _ in range(n)] for _ in range(n)]
        for k in range(n):
            for i in range(n):
                for j in range(i, n):
                    dM[k][i][j] = dM[k][j][i] = M[i][j].derivative(k)
        check()
        c3 = [[[Series(n)] * n for _ in range(n)] for _ in range(n)]
        for i in range(n):
            for j in range(n):
                for k in range(j, n):
                    s = (dM[k][i][j] + dM[j][i][k] - dM[i][j][k]).scale(HALF)
                    c3[i][j][k] = c3[i][k][j] = s
            check()
        dq = [Series.variable(n, n + k) for k in range(n)]
        C = [[_sum_products(c3[i][j], dq, n) for j in range(n)] for i in range(n)]
        T = Series(n)
        for i in range(n):
            for j in range(i, n):
                weight = HALF if i == j else Decimal(1)
                T = T + (M[i][j] * dq[i] * dq[j]).scale(weight)
    far = max(reach(model, joints), default=1.0)
    # a dropped term of M (frequency ≤ 2, degree ≤ 2) changes c_ijk by at most 3×, C_ij by
    # 3 n× (Σ_k over ‖q̇‖∞ ≤ 1) and T by ½ n²×; one of U (frequency, degree ≤ 1) g by 1×
    noise_m, noise_u = lost_m * far**2, lost_u * far
    noise = {
        "mass_matrix": noise_m,
        "coriolis_matrix": 3 * n * noise_m,
        "kinetic_energy": 0.5 * n * n * noise_m,
        "potential_energy": noise_u,
        "gravity": noise_u,
    }
    return ExplicitEquations(
        joints=[j.name for j in joints],
        kinds=[j.kind for j in joints],
        mass_matrix=M,
        gravity=g,
        christoffel=c3,
        coriolis_matrix=C,
        kinetic_energy=T,
        potential_energy=U,
        seconds=time.monotonic() - start,
        reach=reach(model, joints),
        parameters=parameters,
        noise=noise,
    )


def _sum_products(a: list[Series], b: list[Series], n: int) -> Series:
    out = Series(n)
    for x, y in zip(a, b, strict=True):
        if x.terms:
            out = out + x * y
    return out
