"""Exact trigonometric polynomials: the algebra the equations of motion are derived in.

A `Series` over n joint coordinates is a finite sum of terms

    a · x^e · cos(k·q)    or    a · x^e · sin(k·q)

with an exact rational coefficient a (`fractions.Decimal`), an integer frequency vector k (one
entry per coordinate; zero for prismatic ones), and a monomial x^e in the polynomial variables
x = (q₁ … qₙ, dq₁ … dqₙ) — the prismatic coordinates and the joint velocities (e has 2n entries).
A term may also carry one inertial parameter symbol p_j (j ≥ 1; 0 for none) as a factor: the
parametric form, linear in the parameters (see `parameter`).

The form is canonical: the first non-zero entry of k is positive (cos(−θ) = cos θ,
sin(−θ) = −sin θ), a term with k = 0 is a cosine (sin 0 = 0, cos 0 = 1), and no coefficient is
zero. Products use the product-to-sum identities, so cos q₁ cos q₂ becomes
½ cos(q₁ + q₂) + ½ cos(q₁ − q₂) and sin² q₂ becomes ½ − ½ cos 2q₂: two equal trigonometric
polynomials have the same terms, and sums of angles appear where they arise. Derivatives are
exact: ∂/∂qᵢ cos(k·q) = −kᵢ sin(k·q), ∂/∂qᵢ sin(k·q) = kᵢ cos(k·q), ∂/∂xᵢ x^e = eᵢ x^(e−1).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Sequence
from decimal import Context, Decimal

# A term's key: (k, e, kind) with kind 0 = cos(k·q), 1 = sin(k·q), and the vectors k and e
# packed into integers, digit i (most significant first) in base BASE: k = Σ kᵢ BASEⁿ⁻¹⁻ⁱ (digits
# in −BASE/2 … BASE/2, so k's sign is the sign of its first non-zero entry), e likewise over
# 2n non-negative digits. Adding or subtracting frequency vectors or monomial exponents is then
# adding or subtracting integers. The parameter symbol of a term, if any, is its index j times
# BASE^(2n) in e: above the monomial's digits, so a product of a parametric and a numeric term
# carries it (a product of two parametric terms never occurs: the equations are linear in it).
Key = tuple[int, int, int]
COS, SIN = 0, 1
BASE = 1024
ZERO, HALF, ONE = Decimal(0), Decimal("0.5"), Decimal(1)

# Significant digits of the coefficient arithmetic: a product of three model numbers (≤ 17
# digits each) is exact; longer chains are rounded 40 digits beyond double precision. Every
# operation uses this context explicitly, whatever the thread's decimal context is.
PRECISION = 60
CONTEXT = Context(prec=PRECISION)
_add, _mul, _neg = CONTEXT.add, CONTEXT.multiply, CONTEXT.minus


def pack(digits: Iterable[int]) -> int:
    """The integer of a digit vector (most significant first), see `Key`."""
    out = 0
    for d in digits:
        out = out * BASE + d
    return out


@functools.lru_cache(maxsize=1 << 16)
def unpack(value: int, size: int) -> tuple[int, ...]:
    """The `size` balanced digits of a packed vector (inverse of `pack`)."""
    digits = []
    for _ in range(size):
        d = value % BASE
        if d >= BASE // 2:
            d -= BASE
        digits.append(d)
        value = (value - d) // BASE
    return tuple(reversed(digits))


def unpack_key(key: Key, n: int) -> tuple[tuple[int, ...], tuple[int, ...], int]:
    """(k, e, kind) of a key as plain tuples: k over the n coordinates, e over (q, dq) (the
    parameter symbol left out: `parameter_index`)."""
    return unpack(key[0], n), unpack(key[1] % BASE ** (2 * n), 2 * n), key[2]


def parameter_index(e: int, n: int) -> int:
    """The parameter symbol's index j of a term's packed monomial e (0: none)."""
    index: int = e // BASE ** (2 * n)
    return index


class Series:
    """A trigonometric polynomial in n coordinates (see the module docstring). Immutable by
    convention: every operation returns a new Series."""

    __slots__ = ("n", "terms")

    def __init__(self, n: int, terms: dict[Key, Decimal] | None = None) -> None:
        self.n = n
        self.terms: dict[Key, Decimal] = terms if terms is not None else {}

    # -- constructors ----------------------------------------------------------------------
    @classmethod
    def constant(cls, n: int, value: Decimal) -> Series:
        if value == 0:
            return cls(n)
        return cls(n, {(0, 0, COS): Decimal(value)})

    @classmethod
    def trig(cls, n: int, i: int, kind: int) -> Series:
        """cos(qᵢ) or sin(qᵢ) (i from 0)."""
        return cls(n, {(BASE ** (n - 1 - i), 0, kind): ONE})

    @classmethod
    def parameter(cls, n: int, index: int) -> Series:
        """The parameter symbol p_index (index from 1) as a series: one term of coefficient 1."""
        return cls(n, {(0, index * BASE ** (2 * n), COS): ONE})

    @classmethod
    def variable(cls, n: int, index: int) -> Series:
        """The polynomial variable x_index: q_index for index < n, dq_(index−n) after."""
        return cls(n, {(0, BASE ** (2 * n - 1 - index), COS): ONE})

    # -- algebra ---------------------------------------------------------------------------
    def is_zero(self) -> bool:
        return not self.terms

    def __add__(self, other: Series) -> Series:
        if not other.terms:
            return self
        if not self.terms:
            return other
        out = dict(self.terms)
        for key, c in other.terms.items():
            s = _add(out[key], c) if key in out else c
            if s:
                out[key] = s
            else:
                out.pop(key, None)
        return Series(self.n, out)

    def __neg__(self) -> Series:
        return Series(self.n, {key: _neg(c) for key, c in self.terms.items()})

    def __sub__(self, other: Series) -> Series:
        return self + (-other)

    def scale(self, factor: Decimal) -> Series:
        if factor == 0:
            return Series(self.n)
        return Series(self.n, {key: _mul(c, factor) for key, c in self.terms.items()})

    def constant_value(self) -> Decimal | None:
        """The value when the series is a constant (or zero), else None."""
        if not self.terms:
            return ZERO
        if len(self.terms) == 1:
            (k, e, _), c = next(iter(self.terms.items()))
            if not k and not e:
                return c
        return None

    def __mul__(self, other: Series) -> Series:
        a = self.constant_value()
        if a is not None:
            return other.scale(a)
        b = other.constant_value()
        if b is not None:
            return self.scale(b)
        if len(other.terms) == 1:  # a monomial (or parameter) of coefficient 1: shift e
            (k, e, _), c = next(iter(other.terms.items()))
            if not k and c == ONE:
                return Series(
                    self.n, {(ka, ea + e, ta): ca for (ka, ea, ta), ca in self.terms.items()}
                )
        out: dict[Key, Decimal] = {}
        half = HALF

        def put(k: int, e: int, kind: int, c: Decimal) -> None:
            if k < 0:  # cos(−θ) = cos θ, sin(−θ) = −sin θ
                k = -k
                if kind == SIN:
                    c = _neg(c)
            elif k == 0 and kind == SIN:
                return
            key = (k, e, kind)
            s = _add(out[key], c) if key in out else c
            if s:
                out[key] = s
            else:
                out.pop(key, None)

        for (ka, ea, ta), ca in self.terms.items():
            for (kb, eb, tb), cb in other.terms.items():
                e = ea + eb
                if not ka:  # cos 0 = 1
                    put(kb, e, tb, _mul(ca, cb))
                    continue
                if not kb:
                    put(ka, e, ta, _mul(ca, cb))
                    continue
                c = _mul(_mul(ca, cb), half)
                ks, kd = ka + kb, ka - kb
                if ta == COS and tb == COS:  # cos a cos b = ½ cos(a−b) + ½ cos(a+b)
                    put(kd, e, COS, c)
                    put(ks, e, COS, c)
                elif ta == SIN and tb == SIN:  # sin a sin b = ½ cos(a−b) − ½ cos(a+b)
                    put(kd, e, COS, c)
                    put(ks, e, COS, _neg(c))
                elif ta == SIN:  # sin a cos b = ½ sin(a+b) + ½ sin(a−b)
                    put(ks, e, SIN, c)
                    put(kd, e, SIN, c)
                else:  # cos a sin b = ½ sin(a+b) − ½ sin(a−b)
                    put(ks, e, SIN, c)
                    put(kd, e, SIN, _neg(c))
        return Series(self.n, out)

    def derivative(self, index: int) -> Series:
        """∂/∂x_index, x = (q₁ … qₙ, dq₁ … dqₙ) from 0: the trigonometric part for a
        revolute coordinate, the monomial part for every variable."""
        out: dict[Key, Decimal] = {}
        n = self.n
        unit = BASE ** (2 * n - 1 - index)
        for (k, e, kind), c in self.terms.items():
            ki = unpack(k, n)[index] if index < n and k else 0
            if ki:
                # d/dq cos(k·q) = −k_i sin(k·q); d/dq sin(k·q) = k_i cos(k·q)
                new_kind = SIN if kind == COS else COS
                dc = _mul(c, Decimal(-ki if kind == COS else ki))
                key = (k, e, new_kind)
                out[key] = _add(out[key], dc) if key in out else dc
            ei = (e // unit) % BASE
            if ei:
                key = (k, e - unit, kind)
                de = _mul(c, Decimal(ei))
                out[key] = _add(out[key], de) if key in out else de
        return Series(self.n, {key: c for key, c in out.items() if c})

    # -- inspection ------------------------------------------------------------------------
    def coordinates(self) -> list[int]:
        """Indices (from 0) of the coordinates qᵢ the series depends on."""
        used = [False] * self.n
        for key in self.terms:
            k, e, _ = unpack_key(key, self.n)
            for i in range(self.n):
                if k[i] or e[i]:
                    used[i] = True
        return [i for i in range(self.n) if used[i]]

    def evaluate(
        self,
        q: Sequence[float],
        dq: Sequence[float] | None = None,
        parameters: Sequence[float] | None = None,
    ) -> float:
        """The value at joint positions q (rad or m) and velocities dq, in double precision;
        a parametric series with the values of p1, p2, … in `parameters`."""
        x = [float(v) for v in q] + [float(v) for v in (dq if dq is not None else [0.0] * self.n)]
        out = 0.0
        for key, c in self.terms.items():
            k, e, kind = unpack_key(key, self.n)
            angle = sum(ki * x[i] for i, ki in enumerate(k) if ki)
            value = float(c) * (math.cos(angle) if kind == COS else math.sin(angle))
            for i, ei in enumerate(e):
                if ei:
                    value *= x[i] ** ei
            j = parameter_index(key[1], self.n)
            if j:
                if parameters is None:
                    raise ValueError("a parametric series needs the parameters' values")
                value *= float(parameters[j - 1])
            out += value
        return out

    def largest_coefficient(self) -> Decimal:
        return max((c.copy_abs() for c in self.terms.values()), default=ZERO)

    def rounded(self, digits: int) -> Series:
        """The series with every coefficient rounded to `digits` significant digits."""
        plus = Context(prec=digits).plus
        return Series(self.n, {key: plus(c) for key, c in self.terms.items()})

    def without_terms_below(self, bound: Decimal) -> Series:
        """The series less its terms whose coefficient is at most `bound` in magnitude."""
        return Series(self.n, {key: c for key, c in self.terms.items() if c.copy_abs() > bound})
