"""The parametric form: the equations linear in the robot's base inertial parameters p1 … pr.

M(q) and U(q) are linear in the standard inertial parameters π (identification's 10 per body,
about the joint origin, in joint order, named as the contract names them: `<joint>.m`,
`<joint>.mx`, `<joint>.my`, `<joint>.mz` (the first moment m·c, identification's `m_cx` …),
`<joint>.Ixx`, `<joint>.Ixy`, `<joint>.Iyy`, `<joint>.Ixz`, `<joint>.Iyz`, `<joint>.Izz`; and
`<joint>.armature` for each joint whose armature is not 0): M = Σₖ πₖ Φₖ(q). Torques see
only the regressor's column space, r = its rank combinations of π
(`identification.base_parameters`: the columns stacked over random states, Gram-Schmidt in
the parameters' order, β = P π with the heads' Φ spanning every Φ). So:

1. M and U are written with a symbol x_h for each head parameter h (the others 0), from
   Pinocchio's numbers on a grid of joint positions (`sampled`): M = Σ_h x_h Φ_h, and
   M(π) = M(x = β).
2. The parameters of the answer are the coefficients the equations themselves show: going
   through the entries of M (upper triangle, row by row) and then U, each term's coefficient is
   a linear functional of x; the first r independent ones (Gram-Schmidt, significant terms
   before residues) become p1 … pr, each scaled so that its first standard parameter (in
   identification's order) has coefficient 1. For the two-link planar arm: p1 = M11's constant,
   p2 its cos q2 coefficient's parameter (the elbow's first moment along the link), … — the
   textbook form M11 = p1 + 2 l1 (p2 cos q2 + p4 sin q2).
3. x = F⁻¹ p (F the chosen functionals, r×r), and every coefficient is rewritten over p.

Each p has its expression in the standard parameters (F P) and its value F x, x the heads'
values fitted to Pinocchio's own M and U on the sampling grid (`sampled.head_values`: exact to
double precision, where P π carries the rounding of the combination K). U's constant
term (which no torque sees, so no base parameter holds it) is left out: U is defined up to a
constant.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from decimal import Decimal
from typing import Any

import numpy as np

from service.dynamics.equations.deviations import standard_deviations
from service.dynamics.equations.model_numbers import Joint
from service.dynamics.equations.series import BASE, Series, unpack
from service.dynamics.identification.base_parameters import (
    BaseParameters,
    base_parameters,
    random_states_count,
)
from service.dynamics.identification.parameters import (
    PER_BODY,
    body_names,
    inertial_parameters,
)
from service.dynamics.identification.regressor import joint_torque_regressor

SIGNIFICANT = 1e-6  # a functional this small relative to its quantity's largest is a residue
INDEPENDENT = 1e-6  # the remainder of a unit functional that still counts as independent
HEAD = 1e-9  # a standard parameter's coefficient this small relative to the largest is 0
# coefficients over p this small relative to their term's largest are 0: the change of
# basis' rounding (a few ulps); a model's own small terms (the UR5's 4.9e-12 rad tilts) stay
NOISE = 1e-14
# a value this small relative to the largest is the fit's rounding: 0 (the planar arm's p3)
ZERO_VALUE = 1e-14
EPSILON = float(np.finfo(float).eps)
PRISMATIC_REACH = 1.0  # m: a prismatic joint's sampled range without finite limits
# the names of a body's 10 standard parameters in the expressions, in identification's order
# (its `LAYOUT`: m, m_cx, m_cy, m_cz, Ixx, …): the first moment m·c is `mx`, `my`, `mz`
LAYOUT = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")


@dataclass(frozen=True)
class BaseParameter:
    """One symbol of the parametric form: its expression in the standard parameters, its
    value and, on a robot made by identification, its standard deviation (`deviations`; None:
    unknown), in the expression's units: kg, kg·m or kg·m²."""

    symbol: str
    expression: str
    value: float
    standard_deviation: float | None = None

    def as_dict(self) -> dict[str, Any]:
        return {
            "symbol": self.symbol,
            "expression": self.expression,
            "value": self.value,
            "standard_deviation": self.standard_deviation,
        }


def standard_parameters(model: Any, joints: list[Joint]) -> tuple[list[str], np.ndarray]:
    """(names, values) of π: identification's 10 per body (`<joint>.m`, `<joint>.mx`, …,
    `LAYOUT`), then each non-zero armature."""
    names = [f"{body}.{name}" for body in body_names(model) for name in LAYOUT]
    values = [inertial_parameters(model)]
    for j in joints:
        if j.armature != 0:
            names.append(f"{j.name}.armature")
            values.append(np.array([float(j.armature)]))
    return names, np.concatenate(values)


def regressor_base(model: Any, joints: list[Joint], names: list[str]) -> BaseParameters:
    """The base parameters of the joint-torque regressor [Y | armature columns] over random
    states (identification's `base_parameters`)."""
    nv = len(joints)
    lower = np.array([-math.pi if j.kind == "revolute" else -PRISMATIC_REACH for j in joints])
    upper = -lower
    for i in range(nv):
        lo, hi = model.lowerPositionLimit[i], model.upperPositionLimit[i]
        if joints[i].kind == "prismatic" and math.isfinite(lo) and math.isfinite(hi) and hi > lo:
            lower[i], upper[i] = lo, hi
    armature = [i for i, j in enumerate(joints) if j.armature != 0]
    data = model.createData()

    def columns(rng: np.random.Generator, count: int) -> np.ndarray:
        q = rng.uniform(lower, upper, size=(count, nv))
        v, a = rng.standard_normal((2, count, nv))
        y = joint_torque_regressor(model, data, q, v, a)
        extra = np.zeros((count, nv, len(armature)))
        for col, i in enumerate(armature):
            extra[:, i, col] = a[:, i]
        return np.concatenate([y, extra], axis=2).reshape(-1, len(names))

    return base_parameters(columns, names, random_states_count(len(names), nv))


@dataclass(frozen=True)
class Symbols:
    """The head parameters as symbols x1 … xr of the derivation (see the module docstring)."""

    n: int
    base: BaseParameters  # identification's: `independent` are the head parameters' columns
    names: list[str]
    values: np.ndarray

    def armature(self, joints: list[Joint]) -> dict[int, int]:
        """Joint index → the symbol of its armature, for the joints whose armature is a
        head parameter."""
        out = {}
        for i, j in enumerate(joints):
            name = f"{j.name}.armature"
            if name in self.names:
                where = np.flatnonzero(self.base.independent == self.names.index(name))
                if where.size:
                    out[i] = int(where[0]) + 1
        return out


def symbols(model: Any, joints: list[Joint]) -> Symbols:
    """The symbols of `model`'s head parameters."""
    names, values = standard_parameters(model, joints)
    return Symbols(len(joints), regressor_base(model, joints, names), names, values)


def _grouped(s: Series, n: int, r: int) -> tuple[list[tuple[int, int, int]], np.ndarray]:
    """A parametric series' terms grouped by (k, e without the symbol, kind): the groups' keys
    and their coefficients over x1 … xr (groups × r)."""
    scale = BASE ** (2 * n)
    index: dict[tuple[int, int, int], int] = {}
    rows, cols, values = [], [], []
    for (k, e, kind), c in s.terms.items():
        j, low = divmod(e, scale)
        if not j:
            continue
        rows.append(index.setdefault((k, low, kind), len(index)))
        cols.append(j - 1)
        values.append(float(c))
    out = np.zeros((len(index), r))
    np.add.at(out, (np.array(rows, dtype=int), np.array(cols, dtype=int)), values)
    return list(index), out


def _functionals(
    groups: list[tuple[list[tuple[int, int, int]], np.ndarray]], n: int
) -> list[np.ndarray]:
    """Each term's coefficient over x1 … xr (vectors), in the entries' order (`groups`: each
    entry's `_grouped`), the terms of an entry by the coordinates they depend on; significant
    ones first. U, the last entry, is taken without its constant term."""
    out: list[np.ndarray] = []
    for index, (keys, matrix) in enumerate(groups):
        last = index == len(groups) - 1
        order = sorted(range(len(keys)), key=lambda g: _order(keys[g], n))
        out.extend(matrix[g] for g in order if not (last and not keys[g][0] and not keys[g][1]))
    largest = max((float(np.abs(v).max()) for v in out), default=0.0)
    significant = [v for v in out if np.abs(v).max() >= SIGNIFICANT * largest]
    rest = [v for v in out if np.abs(v).max() < SIGNIFICANT * largest]
    return significant + rest


def _order(key: tuple[int, int, int], n: int) -> tuple[int, ...]:
    k, low, kind = key
    freq = unpack(k, n) if k else (0,) * n
    used = [i for i, x in enumerate(freq) if x]
    return (low, len(used), *used, *(abs(x) for x in freq), kind)


def _chosen(functionals: list[np.ndarray], r: int) -> np.ndarray:
    """The first r independent functionals (rows, r×r)."""
    basis = np.zeros((0, r))
    rows = []
    for vec in functionals:
        size = float(np.linalg.norm(vec))
        if size == 0.0:
            continue
        unit = vec / size
        for _ in range(2):
            unit = unit - basis.T @ (basis @ unit)
        rest = float(np.linalg.norm(unit))
        if rest > INDEPENDENT:
            rows.append(vec)
            basis = np.vstack([basis, unit / rest])
            if len(rows) == r:
                break
    if len(rows) < r:
        raise ArithmeticError(f"the equations show {len(rows)} of the {r} base parameters")
    return np.array(rows)


def _expression(row: np.ndarray, names: list[str]) -> str:
    """A functional of π as text: `shoulder.Iyy + elbow.m + 0.5 elbow.Iyy` (6 digits)."""
    text = ""
    for col in np.flatnonzero(row):
        c = float(row[col])
        size = abs(c)
        term = names[col] if abs(size - 1.0) < 1e-9 else f"{size:.6g} {names[col]}"
        if not text:
            text = term if c > 0 else f"-{term}"
        else:
            text += f" - {term}" if c < 0 else f" + {term}"
    return text


def _rewritten(
    grouped: tuple[list[tuple[int, int, int]], np.ndarray],
    inverse: np.ndarray,
    n: int,
    values: np.ndarray,
    shown: np.ndarray,
    heads: np.ndarray,
    states: int,
) -> tuple[Series, float]:
    """A series over x (its `_grouped` terms) rewritten over p (x = F⁻¹ p), and what the
    rewriting changes of it at most at the values, each term's factor at most 1: the `NOISE`
    cut and the values as shown (`shown`, the true ones `values`), Σ |dropped coefficient|
    |value| + Σ |kept coefficient| |value − shown|, and the change of basis' rounding,
    Σ |(coefficients over p) · values − (coefficients over x) · x| per term (x = `heads`); and
    an allowance for the float transform and fit the coefficients come from, `states` (the
    grid's size) × ε × Σ |coefficient| |value| (measured within it: tests at random states)."""
    scale = BASE ** (2 * n)
    keys, matrix = grouped
    if not keys:
        return Series(n), 0.0
    over_p = matrix @ inverse
    cut = NOISE * np.abs(over_p).max(axis=1, keepdims=True)
    kept = np.abs(over_p) > cut
    size = np.abs(over_p)
    lost = float(((size * ~kept) @ np.abs(values) + (size * kept) @ np.abs(values - shown)).sum())
    lost += float(np.abs(over_p @ values - matrix @ heads).sum())
    lost += states * EPSILON * float(((size * kept) @ np.abs(values)).sum())
    terms = {}
    for g, col in zip(*np.nonzero(kept), strict=True):
        k, low, kind = keys[g]
        terms[(k, low + (int(col) + 1) * scale, kind)] = Decimal(repr(float(over_p[g, col])))
    return Series(n, terms), lost


def in_base_parameters(
    sym: Symbols,
    mass_matrix: list[list[Series]],
    potential: Series,
    heads: np.ndarray,
    uncertainty: Mapping[str, Any] | None = None,
) -> tuple[list[list[Series]], Series, list[BaseParameter], tuple[float, float]]:
    """(M, U without its constant term, the parameters, lost) over p1 … pr (module
    docstring); `heads` are the values of x1 … xr, each p's value is F x; lost = (M's, U's)
    largest bound over an entry of what the cuts change (`_rewritten`); with
    identification's `uncertainty` (a robot it made), each p's standard deviation
    (`deviations`)."""
    n, r = sym.n, sym.base.count
    pairs = [(i, j) for i in range(n) for j in range(i, n)]
    groups = [_grouped(mass_matrix[i][j], n, r) for i, j in pairs] + [_grouped(potential, n, r)]
    chosen = _chosen(_functionals(groups, n), r)
    standard = chosen @ sym.base.projection()
    for k in range(r):
        row = standard[k]
        row[np.abs(row) < HEAD * float(np.abs(row).max())] = 0.0
        head = float(row[np.flatnonzero(row)[0]])
        standard[k] /= head
        chosen[k] /= head
    inverse = np.linalg.inv(chosen)
    exact = chosen @ heads
    values = exact.copy()
    # a value at the fit's rounding is 0 (a centre of mass on a link's line)
    values[np.abs(values) <= ZERO_VALUE * float(np.abs(values).max(initial=0.0))] = 0.0
    M = [[Series(n)] * n for _ in range(n)]
    lost_m = 0.0
    for (i, j), grouped in zip(pairs, groups, strict=False):
        M[i][j], lost = _rewritten(grouped, inverse, n, exact, values, heads, 5 ** (n - 1))
        M[j][i] = M[i][j]
        lost_m = max(lost_m, lost)
    U, lost_u = _rewritten(groups[-1], inverse, n, exact, values, heads, 3**n)
    U = Series(n, {key: c for key, c in U.terms.items() if key[0] or key[1] % BASE ** (2 * n)})
    deviations: list[float | None] = [None] * r
    if uncertainty is not None:
        deviations = standard_deviations(standard, PER_BODY * sym.n, uncertainty)
    parameters = [
        BaseParameter(
            f"p{k + 1}", _expression(standard[k], sym.names), float(values[k]), deviations[k]
        )
        for k in range(r)
    ]
    return M, U, parameters, (lost_m, lost_u)
