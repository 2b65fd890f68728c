"""SymPy's sparse polynomial rings in place of the equations' own trigonometric series.

    .venv/bin/python bench/equations_polys.py              # UR5, skewed 4-joint arm; QQ and RR
    .venv/bin/python bench/equations_polys.py --five       # also the skewed 5-joint arm (~30 s)

The composite-rigid-body recursion of `service.dynamics.equations.derivation` runs unchanged on
elements of `sympy.polys.rings.ring` over the generators cᵢ = cos qᵢ, sᵢ = sin qᵢ and the
polynomial variables (prismatic coordinates, velocities), over `QQ` (exact rationals) or a
200-bit `RealField`, and is timed against the same recursion on `Series`. The ring's M is then
reduced modulo cᵢ² + sᵢ² − 1 (`PolyElement.rem`), which gives a normal form in cos and sin —
not yet the Fourier form (sums of angles) the answer is written in. The figures and the
conclusion are in docs/equations.md, "Why not trigsimp".
"""

from __future__ import annotations

import argparse
import time
from decimal import Decimal
from typing import Any

import sympy as sp
from sympy.polys.domains import QQ, RealField
from sympy.polys.rings import ring

import service.dynamics.equations.derivation as derivation
from bench.equations import skewed_arm
from service.dynamics.equations.model_numbers import gravity, moving_joints
from service.dynamics.equations.series import Series
from service.registry.catalog import load_catalog


def ring_series(n: int, domain: Any) -> tuple[type, Any]:
    """A class with the interface of `Series` the recursion uses, over a polynomial ring."""
    names = [f"c{i}" for i in range(n)] + [f"s{i}" for i in range(n)]
    names += [f"x{i}" for i in range(2 * n)]
    poly_ring, *gens = ring(",".join(names), domain)

    def number(d: Decimal) -> Any:
        return domain.convert(sp.Rational(str(d))) if domain is QQ else domain(str(d))

    class RingSeries:
        __slots__ = ("n", "terms")

        def __init__(self, n: int, poly: Any = None) -> None:
            self.n = n
            self.terms = poly if poly is not None else poly_ring.zero

        @classmethod
        def constant(cls, n: int, v: Decimal) -> RingSeries:
            return cls(n, poly_ring(number(v)))

        @classmethod
        def trig(cls, n: int, i: int, kind: int) -> RingSeries:
            return cls(n, gens[i] if kind == 0 else gens[n + i])

        @classmethod
        def variable(cls, n: int, index: int) -> RingSeries:
            return cls(n, gens[2 * n + index])

        def __add__(self, o: RingSeries) -> RingSeries:
            return RingSeries(self.n, self.terms + o.terms)

        def __sub__(self, o: RingSeries) -> RingSeries:
            return RingSeries(self.n, self.terms - o.terms)

        def __neg__(self) -> RingSeries:
            return RingSeries(self.n, -self.terms)

        def __mul__(self, o: RingSeries) -> RingSeries:
            return RingSeries(self.n, self.terms * o.terms)

        def scale(self, d: Decimal) -> RingSeries:
            return RingSeries(self.n, self.terms * number(d))

        def largest_coefficient(self) -> Decimal:
            return Decimal(repr(float(max((abs(c) for c in self.terms.values()), default=0))))

        def without_terms_below(self, bound: Decimal) -> RingSeries:
            b = number(bound)
            return RingSeries(
                self.n, poly_ring({m: c for m, c in self.terms.items() if abs(c) > b})
            )

    return RingSeries, poly_ring


def measure(name: str, model: Any, domain: Any) -> None:
    joints = moving_joints(model)
    n = len(joints)
    t0 = time.perf_counter()
    derivation.mass_matrix_and_potential(joints, gravity(model), lambda: None)
    series_s = time.perf_counter() - t0
    ring_class, poly_ring = ring_series(n, domain)
    derivation.Series = ring_class  # type: ignore[misc]
    try:
        t0 = time.perf_counter()
        M, _ = derivation.mass_matrix_and_potential(joints, gravity(model), lambda: None)
        ring_s = time.perf_counter() - t0
    finally:
        derivation.Series = Series  # type: ignore[misc]
    upper = [M[i][j].terms for i in range(n) for j in range(i, n)]
    pythagoras = [poly_ring.gens[i] ** 2 + poly_ring.gens[n + i] ** 2 - 1 for i in range(n)]
    t0 = time.perf_counter()
    reduced = [p.rem(pythagoras) for p in upper]
    rem_s = time.perf_counter() - t0
    print(
        f"{name:<20} {domain!s:<10} {series_s:>9.3f} {ring_s:>8.2f} "
        f"{sum(len(p) for p in upper):>7} {rem_s:>7.2f} {sum(len(p) for p in reduced):>8}",
        flush=True,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--five", action="store_true", help="include the skewed 5-joint arm")
    args = parser.parse_args()
    robots, _ = load_catalog(["ur5"])
    cases = [("ur5", robots["ur5"].model), ("skewed 4-joint arm", skewed_arm(4))]
    if args.five:
        cases.append(("skewed 5-joint arm", skewed_arm(5)))
    print(
        f"{'robot':<20} {'domain':<10} {'series s':>9} {'ring s':>8} {'terms':>7} "
        f"{'rem s':>7} {'reduced':>8}"
    )
    for name, model in cases:
        for domain in (QQ, RealField(prec=200)):
            if name.startswith("skewed 5") and domain is not QQ:
                continue
            measure(name, model, domain)


if __name__ == "__main__":
    main()
