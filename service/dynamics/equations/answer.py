"""The equations as the JSON answer of `GET /v1/robots/{id}/equations`.

Each quantity is `{"expressions": …, "latex": …}` of the quantity's shape (a scalar is one
string); `structure` gives, per entry of M and g, the coordinates it depends on, whether it is
constant (depends on none) and whether it is identically zero.
"""

from __future__ import annotations

from typing import Any

from service.dynamics.equations.explicit_form import Equations
from service.dynamics.equations.printing import render
from service.dynamics.equations.series import Series


def _expressions(value: Any) -> Any:
    if isinstance(value, Series):
        return render(value)
    return [_expressions(v) for v in value]


def _latex(value: Any) -> Any:
    if isinstance(value, Series):
        return render(value, latex=True)
    return [_latex(v) for v in value]


def _entry(value: Any) -> dict[str, Any]:
    return {"expressions": _expressions(value), "latex": _latex(value)}


def entry_structure(series: Series) -> dict[str, Any]:
    """{"depends_on": ["q2", …], "constant": …, "zero": …} of one entry."""
    depends = [f"q{i + 1}" for i in series.coordinates()]
    return {"depends_on": depends, "constant": not depends, "zero": series.is_zero()}


def equations_answer(eq: Equations) -> dict[str, Any]:
    """The contract's answer: joints, coordinates, velocities, each quantity as expressions and
    LaTeX, and the structure of M and g."""
    n = len(eq.joints)
    return {
        "joints": list(eq.joints),
        "coordinates": [f"q{i + 1}" for i in range(n)],
        "velocities": [f"dq{i + 1}" for i in range(n)],
        "mass_matrix": _entry(eq.mass_matrix),
        "gravity": _entry(eq.gravity),
        "coriolis_matrix": _entry(eq.coriolis_matrix),
        "christoffel": _entry(eq.christoffel),
        "kinetic_energy": _entry(eq.kinetic_energy),
        "potential_energy": _entry(eq.potential_energy),
        "structure": {
            "mass_matrix": [[entry_structure(s) for s in row] for row in eq.mass_matrix],
            "gravity": [entry_structure(s) for s in eq.gravity],
        },
    }
