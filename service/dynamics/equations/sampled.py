"""M(q) and U(q) of each inertial parameter, as trigonometric polynomials, from Pinocchio's
numbers on a grid of joint positions (the parametric form's algebra, `parametric`).

M and U are linear in the standard parameters π: M = Σₖ πₖ Φₖ(q), U = Σₖ πₖ Ψₖ(q). Each Φₖ,
Ψₖ is a trigonometric polynomial of frequency at most 2 in every revolute angle (a body's
inertia is turned by R(q) on both sides: R I Rᵀ; Ψ at most 1) and a polynomial of degree at
most 2 in every prismatic coordinate (m p pᵀ; Ψ at most 1). Such a function is fixed by its
values on a grid of 5 angles per revolute joint (2πm/5, m = 0 … 4; 3 for Ψ) and 3 positions
per prismatic one (−1, 0, 1 m): its coefficients are the grid values' discrete Fourier transform
(cos(k·q): 2 Re ĉₖ, sin(k·q): −2 Im ĉₖ, k's first non-zero entry positive) and, along a
prismatic axis, the parabola through the three values. The values are Pinocchio's:

- Φₖ(q) column j: the joint-torque regressor at (q, v = 0, a = e_j) without gravity
  (identification's `joint_torque_regressor`), column k;
- Ψₖ(q): −g₀ · (the body's origin) for its mass, −g₀ · (the joint frame's axis x, y or z) for
  its first moment m c, 0 for its rotational inertia (forward kinematics);
- an armature parameter: Φ = e_j e_jᵀ, Ψ = 0.

The coefficients are exact to double precision: values below `NOISE` × the largest of the
same quantity are the transform's rounding and are dropped. M needs 5⁵ = 3,125 states of a 6R
arm (it does not depend on q1), U 3⁶ = 729.
"""

from __future__ import annotations

import itertools
import math
from decimal import Decimal
from typing import Any

import numpy as np
import pinocchio as pin

from service.dynamics.equations.model_numbers import Joint
from service.dynamics.equations.series import BASE, COS, SIN, Series, pack
from service.dynamics.identification.parameters import PER_BODY
from service.dynamics.identification.regressor import joint_torque_regressor

NOISE = 1e-13
FIT_STRIDE = 7  # every 7th state of M's grid in the fit of the values (7 is prime to 5 and 3)
POSITIONS = (-1.0, 0.0, 1.0)  # m: samples per prismatic coordinate, degrees 0 … 2
# parabola a + b x + c x² through the values at −1, 0, 1: (a, b, c) = PARABOLA @ values
PARABOLA = np.array([[0.0, 1.0, 0.0], [-0.5, 0.0, 0.5], [0.5, -1.0, 0.5]])


def _samples(joint: Joint, angles: int) -> list[float]:
    """The positions sampled on a joint's axis: `angles` angles of a revolute joint (0 when
    1: a coordinate the quantity does not depend on), 3 positions of a prismatic one."""
    if angles == 1:
        return [0.0]
    if joint.kind == "revolute":
        return [2 * math.pi * m / angles for m in range(angles)]
    return list(POSITIONS)


def _grid(joints: list[Joint], angles: list[int]) -> np.ndarray:
    """The joint positions sampled, (states, n), the last coordinate varying fastest."""
    axes = [_samples(j, a) for j, a in zip(joints, angles, strict=True)]
    return np.array(list(itertools.product(*axes)), dtype=float)


def _mass_values(model: Any, q: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """Φ's values (states, n, n, len(columns)) for the inertial parameters `columns`."""
    still = pin.Model(model)
    still.gravity = pin.Motion.Zero()
    states, n = q.shape
    qs = np.repeat(q, n, axis=0)
    a = np.tile(np.eye(n), (states, 1))
    y = joint_torque_regressor(still, still.createData(), qs, np.zeros_like(qs), a, columns)
    # y[state * n + j, i, k] = M_ij's Φ_k
    return y.reshape(states, n, n, len(columns)).transpose(0, 2, 1, 3)


def _potential_values(model: Any, q: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """Ψ's values (states, len(columns)) for the inertial parameters `columns`."""
    data = model.createData()
    g0 = np.asarray(model.gravity.linear, dtype=float)
    n = q.shape[1]
    # per state and joint: −g₀ · origin, −g₀ · axes x, y, z (the Ψ of m, m cx, m cy, m cz)
    table = np.zeros((q.shape[0], n, PER_BODY))
    for s, qs in enumerate(q):
        pin.forwardKinematics(model, data, qs)
        for b in range(n):
            placement = data.oMi[b + 1]
            table[s, b, 0] = -g0 @ placement.translation
            table[s, b, 1:4] = -g0 @ placement.rotation
    return table[:, columns // PER_BODY, columns % PER_BODY]


def _coefficients(values: np.ndarray, joints: list[Joint], angles: list[int]) -> np.ndarray:
    """The grid values (states, m) → complex coefficients (grid shape…, m): Fourier along the
    revolute axes (ĉ of e^{i k q}, index k mod the angles), parabola (a, b, c) along the
    prismatic ones."""
    shape = [len(_samples(j, a)) for j, a in zip(joints, angles, strict=True)]
    grid = values.reshape(*shape, values.shape[-1]).astype(complex)
    for i, (joint, size) in enumerate(zip(joints, shape, strict=True)):
        if size == 1:
            continue
        if joint.kind == "revolute":
            m = np.arange(size)
            matrix = np.exp(-2j * math.pi * np.outer(m, m) / size) / size
        else:
            matrix = PARABOLA.astype(complex)
        grid = np.moveaxis(np.tensordot(matrix, grid, axes=([1], [i])), 0, i)
    return grid


def _terms(joints: list[Joint], angles: list[int]) -> list[tuple[tuple[int, ...], int, int, bool]]:
    """(grid index, packed k, packed prismatic exponents, k = 0) of every canonical term: k's
    first non-zero entry positive."""
    n = len(joints)
    out = []
    ranges = [range(len(_samples(j, a))) for j, a in zip(joints, angles, strict=True)]
    for index in itertools.product(*ranges):
        k = [0] * n
        e = [0] * (2 * n)
        for i, (j, size) in enumerate(zip(joints, angles, strict=True)):
            if size == 1:
                continue
            if j.kind == "revolute":
                k[i] = index[i] if index[i] <= size // 2 else index[i] - size
            else:
                e[i] = index[i]
        first = next((x for x in k if x), 0)
        if first < 0:
            continue
        out.append((index, pack(k), pack(e), not any(k)))
    return out


def series_of(
    values: np.ndarray, joints: list[Joint], angles: list[int], symbols: list[int]
) -> tuple[list[Series], np.ndarray]:
    """Per group of len(symbols) columns of `values` (states, entries × len(symbols), the
    symbol varying fastest), sampled on `_grid(joints, angles)`: the entry's parametric series
    Σ_h x_h f_h(q), symbol indices `symbols`; and the sum of the |coefficients| the `NOISE`
    cut left out, (entries, len(symbols)): what the cut can change of the entry, per unit of
    each symbol's value (a prismatic factor counted at 1 m)."""
    n = len(joints)
    cut = NOISE * float(np.abs(values).max(initial=0.0))
    live = np.flatnonzero(np.abs(values).max(axis=0, initial=0.0) > 0.0)
    coefficients = _coefficients(values[:, live], joints, angles)
    flat = coefficients.reshape(-1, live.size)
    entries = values.shape[-1] // max(len(symbols), 1)
    terms: list[dict[tuple[int, int, int], Decimal]] = [{} for _ in range(entries)]
    lost = np.zeros(values.shape[-1])
    shape = coefficients.shape[:-1]
    scale = BASE ** (2 * n)
    for index, k, e, constant in _terms(joints, angles):
        row = flat[np.ravel_multi_index(index, shape)]
        cosine = row.real if constant else 2 * row.real
        sine = None if constant else -2 * row.imag
        for kind, part in ((COS, cosine), (SIN, sine)):
            if part is None:
                continue
            small = np.abs(part) <= cut
            lost[live[small]] += np.abs(part[small])
            for col in np.flatnonzero(~small):
                entry, h = divmod(int(live[col]), len(symbols))
                key = (k, e + symbols[h] * scale, kind)
                terms[entry][key] = Decimal(repr(float(part[col])))
    return [Series(n, t) for t in terms], lost.reshape(entries, max(len(symbols), 1))


def head_values(
    model: Any,
    q_mass: np.ndarray,
    mass: np.ndarray,
    q_potential: np.ndarray,
    potential: np.ndarray,
) -> np.ndarray:
    """The values x (columns,) of the symbols whose Φ (states, n, n, columns) and Ψ (states,
    columns) are given: the least-squares fit of Pinocchio's own M (crba; upper triangle, every
    `FIT_STRIDE`-th state: far more equations than unknowns) and U (up to a constant) at the
    same states — exact to double precision, whatever rounding the base parameters'
    combination carries."""
    data = model.createData()
    n = mass.shape[1]
    upper = np.triu_indices(n)
    picked = np.arange(0, q_mass.shape[0], FIT_STRIDE)
    rows_m = mass[picked][:, upper[0], upper[1], :].reshape(-1, mass.shape[-1])
    target_m = np.concatenate([pin.crba(model, data, q_mass[s])[upper] for s in picked])
    target_u = np.array([pin.computePotentialEnergy(model, data, q) for q in q_potential])
    scale_m = max(float(np.abs(target_m).max(initial=0.0)), 1e-300)
    scale_u = max(float(np.abs(target_u).max(initial=0.0)), 1e-300)
    a = np.vstack(
        [
            np.hstack([rows_m / scale_m, np.zeros((rows_m.shape[0], 1))]),
            np.hstack([potential / scale_u, np.ones((potential.shape[0], 1)) / scale_u]),
        ]
    )
    b = np.concatenate([target_m / scale_m, target_u / scale_u])
    solution: np.ndarray = np.linalg.lstsq(a, b, rcond=None)[0][:-1]
    return solution


def mass_matrix_and_potential(
    model: Any, joints: list[Joint], heads: np.ndarray, armature: dict[int, int]
) -> tuple[list[list[Series]], Series, np.ndarray, tuple[float, float]]:
    """(M, U, x, lost) over the symbols x1 … xr of the head parameters, x their values
    (`head_values`), lost = (M's, U's) largest bound over an entry of what the `NOISE` cut
    left out at those values: `heads` are their columns in π (inertial ones below
    10 · bodies), symbol h + 1 for heads[h]; `armature` maps a joint index to the symbol of
    its armature parameter.
    M does not depend on q1 (turning or moving the whole arm about the first joint changes no
    kinetic energy): its grid has one q1."""
    n = len(joints)
    inertial = np.array([h for h in heads if h < PER_BODY * n], dtype=int)
    symbols = [int(np.flatnonzero(heads == h)[0]) + 1 for h in inertial]
    angles = [1] + [5] * (n - 1)  # frequencies −2 … 2
    q = _grid(joints, angles)
    mass = _mass_values(model, q, inertial)
    upper = [(i, j) for i in range(n) for j in range(i, n)]
    stacked = np.stack([mass[:, i, j, :] for i, j in upper], axis=1).reshape(q.shape[0], -1)
    entries, lost_m = series_of(stacked, joints, angles, symbols)
    M = [[Series(n)] * n for _ in range(n)]
    for (i, j), s in zip(upper, entries, strict=True):
        if i == j and i in armature:
            s = s + Series.parameter(n, armature[i])
        M[i][j] = M[j][i] = s
    q_mass = q
    angles = [3] * n  # frequencies −1 … 1
    q = _grid(joints, angles)
    potential = _potential_values(model, q, inertial)
    (U,), lost_u = series_of(potential, joints, angles, symbols)
    # every symbol's Φ and Ψ on the grids (armature: e_j e_jᵀ and 0), for their values
    r = len(heads)
    phi = np.zeros((*mass.shape[:3], r))
    psi = np.zeros((q.shape[0], r))
    for col, symbol in enumerate(symbols):
        phi[..., symbol - 1] = mass[..., col]
        psi[:, symbol - 1] = potential[:, col]
    for joint, symbol in armature.items():
        phi[:, joint, joint, symbol - 1] = 1.0
    x = head_values(model, q_mass, phi, q, psi)
    sizes = np.abs(x[np.array(symbols, dtype=int) - 1]) if symbols else np.zeros(0)
    lost = (float((lost_m @ sizes).max(initial=0.0)), float((lost_u @ sizes).max(initial=0.0)))
    return M, U, x, lost
