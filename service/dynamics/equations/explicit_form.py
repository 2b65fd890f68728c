"""The equations of motion in explicit form, M(q) q̈ + C(q, q̇) q̇ + g(q) = τ, derived
symbolically from a fixed-base model with at most six revolute or prismatic joints.

From M(q) and U(q) (`derivation`), exactly:

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
term can change a double-precision value of the quantity). Everything else — g, c_ijk, C, T — is
derived from the kept terms, so the identities above hold exactly between the expressions.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from decimal import Decimal, localcontext
from typing import Any

from service.dynamics.equations.derivation import deadline_check, mass_matrix_and_potential
from service.dynamics.equations.model_numbers import gravity, moving_joints
from service.dynamics.equations.series import HALF, PRECISION, Series

NOISE = Decimal("1e-14")
# M and U are kept to this many significant digits (23 beyond double precision). Their
# coefficients then span at most 14 orders of magnitude (NOISE), so the sums, halvings and
# integer multiples that give g, c_ijk, C and T fit in `PRECISION` = 60 digits: they are exact,
# and so are the identities Ṁ = C + Cᵀ and g = ∂U/∂q between the expressions.
KEPT_DIGITS = 40


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


def _without_noise(entries: list[Series]) -> list[Series]:
    scale = max((s.largest_coefficient() for s in entries), default=Decimal(0))
    return [s.without_terms_below(scale * NOISE).rounded(KEPT_DIGITS) for s in entries]


def derive_equations(model: Any, time_limit_s: float | None = None) -> ExplicitEquations:
    """The equations of motion of a Pinocchio `model` in explicit form (see the module
    docstring). Raises `UnsupportedModel` for a model out of scope, or when the derivation
    takes longer than `time_limit_s` seconds (checked between steps)."""
    start = time.monotonic()
    check = deadline_check(None if time_limit_s is None else start + time_limit_s, time_limit_s)
    joints = moving_joints(model)
    n = len(joints)
    with localcontext(prec=PRECISION):
        M, U = mass_matrix_and_potential(joints, gravity(model), check)
        flat = _without_noise([M[i][j] for i in range(n) for j in range(n)])
        M = [flat[i * n : (i + 1) * n] for i in range(n)]
        U = _without_noise([U])[0]
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
    )


def _sum_products(a: list[Series], b: list[Series], n: int) -> Series:
    out = Series(n)
    for x, y in zip(a, b, strict=True):
        if x.terms:
            out = out + x * y
    return out
