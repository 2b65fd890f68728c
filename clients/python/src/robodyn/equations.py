"""The answer of `equations(robot_id)`: a robot's equations of motion in explicit form,

    M(q) q̈ + C(q, q̇) q̇ + g(q) = τ,

as text SymPy parses and as LaTeX, with the structure of M and g and the accuracy of the
printed form. Coordinates are `q1 … qn` and velocities `dq1 … dqn`, in the order of `joints`;
the parametric form's base parameters are `p1 … pr` (`parameters`). With SymPy installed
(`pip install 'robodyn[sympy]'`), `.sympy()` turns any quantity into SymPy objects:

    eq = client.equations("planar_arm")
    eq.mass_matrix.expressions[0][0]      # '4.235 + 2.1*cos(q2)'
    M = eq.mass_matrix.sympy()            # sympy.Matrix 2×2 in the symbols q1, q2
    eq.structure.mass_matrix[1][1].constant   # True
    eq.accuracy.max_abs_error["mass_matrix"]  # a bound of |printed − exact| over every q
    p = client.equations("planar_arm", form="parametric")
    p.mass_matrix.expressions[1][1], p.parameters[3].expression  # 'p4', 'elbow.Iyy'
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any


def _sympy() -> Any:
    try:
        import sympy
    except ImportError:  # the optional extra
        raise ImportError(
            "Equations.sympy() needs SymPy: pip install 'robodyn[sympy]' (or sympy)"
        ) from None
    return sympy


def _tuples(value: Any) -> Any:
    return value if isinstance(value, str) else tuple(_tuples(v) for v in value)


@dataclass(frozen=True)
class Expressions:
    """One quantity: `expressions`, text SymPy's `sympify` reads (names q1…, dq1…, p1… in the
    parametric form, `sin`, `cos`, decimals to the accuracy's digits), and `latex`, the same
    terms in LaTeX — a str for a scalar, nested tuples of the quantity's shape otherwise.
    `names` are the coordinate, velocity and parameter names the text uses."""

    expressions: Any
    latex: Any
    names: tuple[str, ...]

    @classmethod
    def from_json(cls, body: Mapping[str, Any], names: tuple[str, ...]) -> Expressions:
        return cls(_tuples(body["expressions"]), _tuples(body["latex"]), names)

    def sympy(self, rational: bool = False) -> Any:
        """The quantity as SymPy objects: an expression for a scalar, a `sympy.Matrix` for a
        vector (a column) or a matrix, a `sympy.Array` for the Christoffel symbols. The symbols
        are `sympy.Symbol(name)` for the names q1…, dq1…, p1… (real). `rational=True` reads the
        decimals as exact rationals. Needs SymPy (the `sympy` extra)."""
        sp = _sympy()
        symbols = {n: sp.Symbol(n, real=True) for n in self.names}

        def parse(value: Any) -> Any:
            if isinstance(value, str):
                return sp.sympify(value, locals=symbols, rational=rational)
            return [parse(v) for v in value]

        parsed = parse(self.expressions)
        if isinstance(self.expressions, str):
            return parsed
        if isinstance(self.expressions[0], str):
            return sp.Matrix(parsed)
        if isinstance(self.expressions[0][0], str):
            return sp.Matrix(parsed)
        return sp.Array(parsed)


@dataclass(frozen=True)
class EntryStructure:
    """Of one entry of M or g: the coordinates it depends on (`depends_on`, e.g. ("q2",)),
    `constant` (depends on none) and `zero` (identically 0)."""

    depends_on: tuple[str, ...]
    constant: bool
    zero: bool

    @classmethod
    def from_json(cls, body: Mapping[str, Any]) -> EntryStructure:
        return cls(tuple(body["depends_on"]), bool(body["constant"]), bool(body["zero"]))


@dataclass(frozen=True)
class EquationsStructure:
    """`mass_matrix` (nv×nv nested tuples) and `gravity` (nv) of `EntryStructure`."""

    mass_matrix: tuple[tuple[EntryStructure, ...], ...]
    gravity: tuple[EntryStructure, ...]

    @classmethod
    def from_json(cls, body: Mapping[str, Any]) -> EquationsStructure:
        return cls(
            tuple(tuple(EntryStructure.from_json(e) for e in row) for row in body["mass_matrix"]),
            tuple(EntryStructure.from_json(e) for e in body["gravity"]),
        )


@dataclass(frozen=True)
class Accuracy:
    """How the printed form may differ from the exact one: coefficients to `digits`
    significant digits, terms below `tolerance` × their quantity's largest coefficient left
    out, and `max_abs_error`, per quantity ("mass_matrix", "gravity", "coriolis_matrix",
    "kinetic_energy", "potential_energy"), a bound over every q of |printed − exact| of any
    entry (C per unit of ‖q̇‖∞, T per unit of ‖q̇‖∞²)."""

    digits: int
    tolerance: float
    max_abs_error: Mapping[str, float]

    @classmethod
    def from_json(cls, body: Mapping[str, Any]) -> Accuracy:
        errors = {k: float(v) for k, v in body["max_abs_error"].items()}
        return cls(int(body["digits"]), float(body["tolerance"]), errors)


@dataclass(frozen=True)
class Parameter:
    """A base inertial parameter of the parametric form: its `symbol` (p1 …), its
    `expression` in the standard parameters (`<joint>.m`, `<joint>.mx`, `<joint>.my`,
    `<joint>.mz` — the first moment m·c, identification's `m_cx` … —, `<joint>.Ixx`, …,
    `<joint>.Izz`, identification's layout, and `<joint>.armature`), its `value` and, on a
    variant stored by identification, its `standard_deviation` from the identification (None
    where unknown: not identified, or not determined by the log)."""

    symbol: str
    expression: str
    value: float
    standard_deviation: float | None = None

    @classmethod
    def from_json(cls, body: Mapping[str, Any]) -> Parameter:
        std = body.get("standard_deviation")
        return cls(
            str(body["symbol"]),
            str(body["expression"]),
            float(body["value"]),
            None if std is None else float(std),
        )


@dataclass(frozen=True)
class Equations:
    """A robot's equations of motion in explicit form (see the module docstring).

    `mass_matrix` M(q) (nv×nv, kg·m², armature included), `gravity` g(q) = ∂U/∂q (nv, N·m),
    `coriolis_matrix` C(q, q̇) (nv×nv, C_ij = Σ_k c_ijk dq_k, so Ṁ = C + Cᵀ),
    `christoffel` c_ijk = ½(∂M_ij/∂q_k + ∂M_ik/∂q_j − ∂M_jk/∂q_i) (nv×nv×nv),
    `kinetic_energy` T = ½ q̇ᵀ M q̇ and `potential_energy` U (J): each an `Expressions`;
    `accuracy` (`Accuracy`) and, in the parametric form, `parameters` (`Parameter`s p1 … pr;
    empty in the numeric form).
    """

    joints: tuple[str, ...]
    coordinates: tuple[str, ...]
    velocities: tuple[str, ...]
    mass_matrix: Expressions
    gravity: Expressions
    coriolis_matrix: Expressions
    christoffel: Expressions
    kinetic_energy: Expressions
    potential_energy: Expressions
    structure: EquationsStructure
    accuracy: Accuracy
    parameters: tuple[Parameter, ...] = ()

    @classmethod
    def from_json(cls, body: Mapping[str, Any]) -> Equations:
        coordinates = tuple(body["coordinates"])
        velocities = tuple(body["velocities"])
        parameters = tuple(Parameter.from_json(p) for p in body.get("parameters") or ())
        names = coordinates + velocities + tuple(p.symbol for p in parameters)

        def read(key: str) -> Expressions:
            return Expressions.from_json(body[key], names)

        return cls(
            tuple(body["joints"]),
            coordinates,
            velocities,
            read("mass_matrix"),
            read("gravity"),
            read("coriolis_matrix"),
            read("christoffel"),
            read("kinetic_energy"),
            read("potential_energy"),
            EquationsStructure.from_json(body["structure"]),
            Accuracy.from_json(body["accuracy"]),
            parameters,
        )

    def symbols(self) -> tuple[Any, Any]:
        """(q, dq): the coordinates and velocities as tuples of SymPy symbols, the ones
        `.sympy()` uses (e.g. for `sympy.lambdify(q, M)`). Needs SymPy."""
        sp = _sympy()
        return (
            tuple(sp.Symbol(n, real=True) for n in self.coordinates),
            tuple(sp.Symbol(n, real=True) for n in self.velocities),
        )
