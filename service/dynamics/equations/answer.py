"""The equations as the JSON answer of `GET /v1/robots/{id}/equations`.

Each quantity is `{"expressions": …, "latex": …}` of the quantity's shape (a scalar is one
string): every entry is converted to a SymPy expression (`printing.to_sympy`) and printed by
SymPy (`sp.sstr`, `sp.latex`). `structure` gives, per entry of M and g, the coordinates it
depends on, whether it is constant (depends on none) and whether it is identically zero.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import sympy as sp

from service.dynamics.equations.explicit_form import ExplicitEquations
from service.dynamics.equations.printing import latex, text, to_sympy
from service.dynamics.equations.series import Series


def _convert(value: Any) -> Any:
    if isinstance(value, Series):
        return to_sympy(value)
    return [_convert(v) for v in value]


def _print(value: Any, printer: Callable[[sp.Expr], str]) -> Any:
    if isinstance(value, list):
        return [_print(v, printer) for v in value]
    return printer(value)


def printed_entry(value: Any, n: int) -> dict[str, Any]:
    """{"expressions": SymPy's text, "latex": SymPy's LaTeX} of a Series or nested lists."""
    exprs = _convert(value)
    return {"expressions": _print(exprs, text), "latex": _print(exprs, lambda e: latex(e, n))}


def entry_structure(series: Series) -> dict[str, Any]:
    """{"depends_on": ["q2", …], "constant": …, "zero": …} of one entry."""
    depends = [f"q{i + 1}" for i in series.coordinates()]
    return {"depends_on": depends, "constant": not depends, "zero": series.is_zero()}


def equations_answer(eq: ExplicitEquations) -> dict[str, Any]:
    """The contract's answer: joints, coordinates, velocities, each quantity as expressions and
    LaTeX, and the structure of M and g."""
    n = len(eq.joints)
    return {
        "joints": list(eq.joints),
        "coordinates": [f"q{i + 1}" for i in range(n)],
        "velocities": [f"dq{i + 1}" for i in range(n)],
        "mass_matrix": printed_entry(eq.mass_matrix, n),
        "gravity": printed_entry(eq.gravity, n),
        "coriolis_matrix": printed_entry(eq.coriolis_matrix, n),
        "christoffel": printed_entry(eq.christoffel, n),
        "kinetic_energy": printed_entry(eq.kinetic_energy, n),
        "potential_energy": printed_entry(eq.potential_energy, n),
        "structure": {
            "mass_matrix": [[entry_structure(s) for s in row] for row in eq.mass_matrix],
            "gravity": [entry_structure(s) for s in eq.gravity],
        },
    }
