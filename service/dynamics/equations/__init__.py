"""The equations of motion in explicit form: M(q), C(q, q̇), g(q), the Christoffel symbols and
the energies of a fixed-base robot with at most six revolute or prismatic joints, derived
symbolically from the model's own numbers (see docs/equations.md).

    series          exact trigonometric polynomials (the algebra; see docs/equations.md,
                    "Why not trigsimp", for why it is not SymPy's)
    model_numbers   the model's joints, placements, axes and inertias as exact decimals; scope
    derivation      M(q) and U(q) by the composite-rigid-body recursion on series
    sampled         the parametric form's M(q), U(q) per head parameter, from Pinocchio's
                    numbers on a grid of joint positions (discrete Fourier transform)
    parametric      the base parameters p1 … pr: which, their expressions and values
    explicit_form   g, Christoffel symbols, C, T from M and U; the noise cut; `derive_equations`
    printing        each entry's text and LaTeX, rounded and cut, with its accuracy bound
    sympy_form      an entry as a SymPy expression (the printed text's reference)
    answer          the JSON answer: accuracy, structure of M and g, parameters

The service derives them in a child process with a time limit and keeps each robot's answer
(`service.api.workers.equations`, `service.api.workers.equations_cache`).
"""

from service.dynamics.equations.answer import equations_answer
from service.dynamics.equations.explicit_form import ExplicitEquations, derive_equations

__all__ = ["ExplicitEquations", "derive_equations", "equations_answer"]
