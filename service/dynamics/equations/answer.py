"""The equations as the JSON answer of `GET /v1/robots/{id}/equations`.

Each quantity is `{"expressions": …, "latex": …}` of the quantity's shape (a scalar is one
string), printed from the exact series (`printing`): coefficients rounded to `digits`
significant digits, and terms whose coefficient is below `tolerance` × the largest coefficient
of the same quantity left out. `accuracy.max_abs_error` bounds, per quantity and over every q,
|printed − exact| of any entry (C per unit of ‖q̇‖∞, T per unit of ‖q̇‖∞²): the sum of what the
left-out terms and the rounding can change (`printing.Printed.error`; in the parametric form
with the parameters' values), and of the derivation's own noise cut (`ExplicitEquations.noise`).
`structure` gives, per entry of M and g, the coordinates its
printed terms depend on, whether it is constant (depends on none) and whether it prints as 0.
The parametric form adds `parameters`: each symbol, its expression in the standard inertial
parameters and its value.
"""

from __future__ import annotations

from typing import Any

from service.dynamics.equations.explicit_form import ExplicitEquations
from service.dynamics.equations.printing import Printed, Printer
from service.dynamics.equations.series import Series

DEFAULT_DIGITS = 6
DEFAULT_TOLERANCE = 1e-9
BOUNDED = ("mass_matrix", "gravity", "coriolis_matrix", "kinetic_energy", "potential_energy")


def _flat(value: Any) -> list[Series]:
    if isinstance(value, Series):
        return [value]
    return [s for v in value for s in _flat(v)]


def _shaped(value: Any, printed: dict[int, Printed], attribute: str) -> Any:
    if isinstance(value, Series):
        return getattr(printed[id(value)], attribute)
    return [_shaped(v, printed, attribute) for v in value]


def _entry_structure(p: Printed) -> dict[str, Any]:
    depends = [f"q{i + 1}" for i in p.depends_on]
    return {"depends_on": depends, "constant": not depends, "zero": p.text == "0"}


def equations_answer(
    eq: ExplicitEquations, digits: int = DEFAULT_DIGITS, tolerance: float = DEFAULT_TOLERANCE
) -> dict[str, Any]:
    """The contract's answer: joints, coordinates, velocities, each quantity as text and LaTeX,
    the accuracy of the printed form, the structure of M and g, and the parameters of a
    parametric `eq` (see the module docstring). `digits` 1–17, `tolerance` ≥ 0 (relative)."""
    n = len(eq.joints)
    printer = Printer(n, digits, eq.reach, [p.value for p in eq.parameters])
    quantities = {
        "mass_matrix": eq.mass_matrix,
        "gravity": eq.gravity,
        "coriolis_matrix": eq.coriolis_matrix,
        "christoffel": eq.christoffel,
        "kinetic_energy": eq.kinetic_energy,
        "potential_energy": eq.potential_energy,
    }
    answer: dict[str, Any] = {
        "joints": list(eq.joints),
        "coordinates": [f"q{i + 1}" for i in range(n)],
        "velocities": [f"dq{i + 1}" for i in range(n)],
    }
    errors: dict[str, float] = {}
    by_quantity: dict[str, dict[int, Printed]] = {}
    for name, value in quantities.items():
        entries = _flat(value)
        largest = max((float(s.largest_coefficient()) for s in entries), default=0.0)
        cut = tolerance * largest
        printed = by_quantity[name] = {}
        for s in entries:
            if id(s) not in printed:
                printed[id(s)] = printer.entry(s, cut)
        answer[name] = {
            "expressions": _shaped(value, printed, "text"),
            "latex": _shaped(value, printed, "latex"),
        }
        errors[name] = max((printed[id(s)].error for s in entries), default=0.0)
        errors[name] += eq.noise.get(name, 0.0)
    answer["accuracy"] = {
        "digits": digits,
        "tolerance": tolerance,
        "max_abs_error": {name: errors[name] for name in BOUNDED},
    }
    m, g = by_quantity["mass_matrix"], by_quantity["gravity"]
    answer["structure"] = {
        "mass_matrix": [[_entry_structure(m[id(s)]) for s in row] for row in eq.mass_matrix],
        "gravity": [_entry_structure(g[id(s)]) for s in eq.gravity],
    }
    if eq.parameters:
        answer["parameters"] = [p.as_dict() for p in eq.parameters]
    return answer
