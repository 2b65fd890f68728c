"""Answer schema of `GET /v1/robots/{id}/equations`: the equations of motion in explicit form.

Each quantity is `{"expressions": …, "latex": …}` of the quantity's shape: text SymPy parses
(`sympify`) with the names of `coordinates` and `velocities` (and p1 … in the parametric form),
`sin`, `cos` and decimal numbers rounded to `accuracy.digits` significant digits, and the same
terms in LaTeX. See docs/equations.md.
"""

from __future__ import annotations

from pydantic import BaseModel, Field

_TEXT = (
    "text SymPy parses (names q1…, dq1…, p1… in the parametric form, sin, cos, numbers to "
    "`accuracy.digits` significant digits); LaTeX in `latex`, same shape"
)


class ScalarExpression(BaseModel):
    expressions: str = Field(description=f"One expression: {_TEXT}.")
    latex: str = Field(description="The same expression in LaTeX.")


class VectorExpressions(BaseModel):
    expressions: list[str] = Field(description=f"nv expressions: {_TEXT}.")
    latex: list[str] = Field(description="The same nv expressions in LaTeX.")


class MatrixExpressions(BaseModel):
    expressions: list[list[str]] = Field(description=f"nv×nv expressions, row-major: {_TEXT}.")
    latex: list[list[str]] = Field(description="The same nv×nv expressions in LaTeX.")


class TensorExpressions(BaseModel):
    expressions: list[list[list[str]]] = Field(
        description=f"nv×nv×nv expressions, [i][j][k] = c_ijk: {_TEXT}."
    )
    latex: list[list[list[str]]] = Field(description="The same nv×nv×nv expressions in LaTeX.")


class EntryStructure(BaseModel):
    depends_on: list[str] = Field(
        description="The coordinates (q1, …) the entry depends on, "
        "in order; empty for a constant entry."
    )
    constant: bool = Field(description="True when `depends_on` is empty.")
    zero: bool = Field(description="True when the entry is identically 0.")


class EquationsStructure(BaseModel):
    mass_matrix: list[list[EntryStructure]] = Field(description="Per entry of M (nv×nv).")
    gravity: list[EntryStructure] = Field(description="Per entry of g (nv).")


class MaxAbsError(BaseModel):
    mass_matrix: float = Field(description="kg·m² (kg on prismatic rows and columns).")
    gravity: float = Field(description="N·m or N.")
    coriolis_matrix: float = Field(description="N·m·s per unit of ‖q̇‖∞ (rad/s or m/s).")
    kinetic_energy: float = Field(description="J per unit of ‖q̇‖∞².")
    potential_energy: float = Field(description="J.")


class Accuracy(BaseModel):
    digits: int = Field(description="Significant digits of the printed coefficients (1–17).")
    tolerance: float = Field(
        description="Terms whose coefficient is below tolerance × the largest coefficient of "
        "the same quantity are left out (0: none)."
    )
    max_abs_error: MaxAbsError = Field(
        description="Per quantity, a bound over every q of |printed − exact| of any entry: "
        "what the left-out terms and the rounding can change (prismatic coordinates within "
        "the larger magnitude of their limits, or 1 m)."
    )


class Parameter(BaseModel):
    symbol: str = Field(description="p1 … pr, as the expressions name it.")
    expression: str = Field(
        description="The base parameter in the standard inertial parameters, named "
        "`<joint>.m`, `<joint>.mx`, `<joint>.my`, `<joint>.mz` (the first moment m·c: "
        "identification's `m_cx`, `m_cy`, `m_cz`), `<joint>.Ixx`, `<joint>.Ixy`, "
        "`<joint>.Iyy`, `<joint>.Ixz`, `<joint>.Iyz`, `<joint>.Izz` (identification's "
        "layout: joint frame, inertia about the joint origin) and `<joint>.armature`; "
        "coefficients to 6 significant digits."
    )
    value: float = Field(description="Its value for this robot (kg, kg·m or kg·m²).")
    standard_deviation: float | None = Field(
        default=None,
        description="On a variant stored by identification: the standard deviation of the "
        "value from the identification's covariance of its base parameters (same units); "
        "null where unknown: a robot not identified, or a parameter the log did not "
        "determine.",
    )


class Equations(BaseModel):
    joints: list[str] = Field(
        description="The moving joints, in the order of q: coordinate "
        "q<i> is joint i's position (rad, or m for a prismatic joint)."
    )
    coordinates: list[str] = Field(description="The coordinate names q1 … qn (nv of them).")
    velocities: list[str] = Field(description="The velocity names dq1 … dqn (rad/s or m/s).")
    mass_matrix: MatrixExpressions = Field(
        description="M(q), nv×nv, symmetric, kg·m² (kg on prismatic rows and columns), the "
        "armature on its diagonal; T = ½ q̇ᵀ M q̇."
    )
    gravity: VectorExpressions = Field(description="g(q) = ∂U/∂q, nv, N·m or N.")
    coriolis_matrix: MatrixExpressions = Field(
        description="C(q, q̇), nv×nv: C_ij = Σ_k c_ijk dq_k, so that Ṁ = C + Cᵀ (the C of the "
        "coriolis route); N·m·s (N·s on prismatic rows)."
    )
    christoffel: TensorExpressions = Field(
        description="Christoffel symbols of the first kind, nv×nv×nv: c_ijk = ½(∂M_ij/∂q_k + "
        "∂M_ik/∂q_j − ∂M_jk/∂q_i), symmetric in j and k."
    )
    kinetic_energy: ScalarExpression = Field(description="T(q, q̇) = ½ q̇ᵀ M q̇, J.")
    potential_energy: ScalarExpression = Field(
        description="U(q), J, zero at the world origin: U = −Σ m g₀·c over the bodies."
    )
    accuracy: Accuracy = Field(description="How the printed form may differ from the exact one.")
    structure: EquationsStructure = Field(
        description="Per entry of M and g (as printed): the coordinates it depends on, "
        "whether it is constant, whether it is zero."
    )
    parameters: list[Parameter] | None = Field(
        default=None,
        description="The parametric form's base parameters p1 … pr (r: the joint-torque "
        "regressor's rank); substituting their values gives the numeric form.",
    )
