"""The readable, exact and parametric forms against Pinocchio: the UR5's default answer (6
digits, no residues, an accuracy bound that holds and is small), the exact form to 1e-12, and
the parametric form (as many parameters as the regressor's rank, linear in them, their values
giving back the numeric form; the two-link arm's textbook M)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import sympy as sp

from service.dynamics.equations import derive_equations, equations_answer
from service.registry.catalog import load_catalog
from tests.helpers import evaluate_printed, random_configuration, skewed_arm_urdf

BOUNDED = ["mass_matrix", "gravity", "coriolis_matrix", "kinetic_energy", "potential_energy"]


@pytest.fixture(scope="module")
def models():
    robots, _ = load_catalog(["ur5", "planar_arm"])
    return {name: robot.model for name, robot in robots.items()}


def _names(n: int, r: int = 0) -> dict[str, sp.Symbol]:
    names = {f"{p}{i}": sp.Symbol(f"{p}{i}") for p in ("q", "dq") for i in range(1, n + 1)}
    names.update({f"p{i}": sp.Symbol(f"p{i}") for i in range(1, r + 1)})
    return names


def _functions(answer: dict, n: int) -> dict:
    """Each bounded quantity's text as a numpy function of (q…, dq…, p…) (no p in the numeric
    form)."""
    r = len(answer.get("parameters", []))
    names = _names(n, r)
    args = [names[f"{x}{i}"] for x in ("q", "dq") for i in range(1, n + 1)]
    args += [names[f"p{i}"] for i in range(1, r + 1)]
    out = {}
    for quantity in BOUNDED:
        expr = sp.sympify(answer[quantity]["expressions"], locals=names)
        expr = sp.Matrix(expr) if isinstance(expr, list) else expr
        out[quantity] = sp.lambdify(args, expr, "numpy")
    return out


def _pinocchio(model, data, q, v) -> dict[str, np.ndarray]:
    M = pin.crba(model, data, q)
    return {
        "mass_matrix": np.triu(M) + np.triu(M, 1).T,
        "gravity": pin.computeGeneralizedGravity(model, data, q),
        "coriolis_matrix": pin.computeCoriolisMatrix(model, data, q, v),
        "kinetic_energy": np.array(pin.computeKineticEnergy(model, data, q, v)),
        "potential_energy": np.array(pin.computePotentialEnergy(model, data, q)),
    }


def _errors(model, answer, functions=None, states=6, seed=2) -> tuple[dict, dict]:
    """Per quantity, the largest |printed − Pinocchio| and the largest |Pinocchio| over random
    states with ‖q̇‖∞ = 1 (U compared up to a constant in the parametric form, which leaves
    out U's constant term)."""
    n = model.nv
    functions = functions or _functions(answer, n)
    p = [x["value"] for x in answer.get("parameters", [])]
    data = model.createData()
    rng = np.random.default_rng(seed)
    worst = dict.fromkeys(BOUNDED, 0.0)
    largest = dict.fromkeys(BOUNDED, 0.0)
    zero = np.zeros(n)
    offset = 0.0
    if p:
        offset = float(functions["potential_energy"](*zero, *zero, *p)) - float(
            pin.computePotentialEnergy(model, data, zero)
        )
    for _ in range(states):
        q = random_configuration(model, rng)
        v = rng.uniform(-1, 1, n)
        v[0] = 1.0
        reference = _pinocchio(model, data, q, v)
        reference["potential_energy"] = reference["potential_energy"] + offset
        for quantity, f in functions.items():
            printed = np.asarray(f(*q, *v, *p), dtype=float).reshape(reference[quantity].shape)
            error = float(np.abs(printed - reference[quantity]).max())
            worst[quantity] = max(worst[quantity], error)
            largest[quantity] = max(largest[quantity], float(np.abs(reference[quantity]).max()))
    return worst, largest


def test_ur5_default_is_readable_and_its_accuracy_bound_holds(models):
    model = models["ur5"]
    answer = equations_answer(derive_equations(model))
    assert answer["accuracy"]["digits"] == 6 and answer["accuracy"]["tolerance"] == 1e-9
    names = _names(6)
    for quantity in BOUNDED:
        texts = np.ravel(answer[quantity]["expressions"])
        numbers = [
            abs(float(x)) for t in texts for x in sp.sympify(t, locals=names).atoms(sp.Float)
        ]
        # 6 significant digits, and no residue: nothing below 1e-9 of the largest coefficient
        for x in numbers:
            assert len(f"{x:.9e}".split("e")[0].replace(".", "").rstrip("0")) <= 6, x
        assert min(numbers) >= 1e-9 * max(numbers), quantity
    worst, largest = _errors(model, answer)
    for quantity in BOUNDED:
        bound = answer["accuracy"]["max_abs_error"][quantity]
        # the bound holds against Pinocchio (plus double rounding of the evaluation) ...
        assert worst[quantity] <= bound + 1e-13 * largest[quantity], quantity
        # ... and is small: below 1e-5 of the quantity's largest entry
        assert bound < 1e-5 * largest[quantity], (quantity, bound, largest[quantity])


def test_exact_form_equals_pinocchio_to_1e_12(models):
    for name in ("ur5", "planar_arm"):
        model = models[name]
        answer = equations_answer(derive_equations(model), 17, 0.0)
        worst, largest = _errors(model, answer)
        for quantity in BOUNDED:
            assert worst[quantity] <= 1e-12 * max(1.0, largest[quantity]), (name, quantity)


def _regressor_rank(model) -> int:
    """The rank of the joint-torque regressor stacked over random states, by SVD."""
    data = model.createData()
    rng = np.random.default_rng(9)
    rows = []
    for _ in range(40):
        q = random_configuration(model, rng)
        v, a = rng.normal(size=model.nv), rng.normal(size=model.nv)
        rows.append(pin.computeJointTorqueRegressor(model, data, q, v, a).copy())
    singular = np.linalg.svd(np.vstack(rows), compute_uv=False)
    return int((singular > 1e-9 * singular[0]).sum())


@pytest.mark.parametrize("name", ["planar_arm", "ur5", "skewed"])
def test_parametric_form_is_linear_in_the_base_parameters_and_gives_back_the_numbers(models, name):
    model = models.get(name) or pin.buildModelFromXML(skewed_arm_urdf(3))
    answer = equations_answer(derive_equations(model, form="parametric"))
    parameters = answer["parameters"]
    r = len(parameters)
    assert r == _regressor_rank(model)
    assert [p["symbol"] for p in parameters] == [f"p{i}" for i in range(1, r + 1)]
    # linear and homogeneous in p: f(a + b) = f(a) + f(b), f(2a) = 2 f(a), at random states
    functions = _functions(answer, model.nv)
    rng = np.random.default_rng(1)
    for _ in range(3):
        q, dq = random_configuration(model, rng), rng.normal(size=model.nv)
        a, b = rng.normal(size=r), rng.normal(size=r)
        for f in functions.values():
            fa, fb = np.asarray(f(*q, *dq, *a)), np.asarray(f(*q, *dq, *b))
            scale = max(1.0, float(np.abs(fa).max()), float(np.abs(fb).max()))
            np.testing.assert_allclose(f(*q, *dq, *(a + b)), fa + fb, atol=1e-9 * scale)
            np.testing.assert_allclose(f(*q, *dq, *(2 * a)), 2 * fa, atol=1e-9 * scale)
            np.testing.assert_allclose(f(*q, *dq, *np.zeros(r)), 0 * fa, atol=0)
    worst, largest = _errors(model, answer, functions)
    for quantity in BOUNDED:
        bound = answer["accuracy"]["max_abs_error"][quantity]
        # U up to a constant: the bound twice (at the state and at the reference state)
        assert worst[quantity] <= 2 * bound + 1e-9 * max(1.0, largest[quantity]), quantity


def test_parameters_are_expressions_in_identifications_standard_parameters(models):
    """Each expression is in the contract's names (`<joint>.m`, `<joint>.mx` = m·cx, …,
    `<joint>.Izz`) and gives the parameter's value from Pinocchio's own parameters."""
    model = models["ur5"]
    answer = equations_answer(derive_equations(model, form="parametric"))
    pi = np.concatenate([model.inertias[j].toDynamicParameters() for j in range(1, model.njoints)])
    layout = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
    standard = {
        f"{model.names[j]}.{k}": float(pi[10 * (j - 1) + i])
        for j in range(1, model.njoints)
        for i, k in enumerate(layout)
    }
    for p in answer["parameters"]:
        # "a.m + 0.425 b.m - c.Izz": signed terms, each an optional coefficient and a name
        value = 0.0
        for term in p["expression"].replace(" - ", " + -").split(" + "):
            sign = -1.0 if term.startswith("-") else 1.0
            parts = term.lstrip("-").split(" ")
            coefficient = float(parts[0]) if len(parts) == 2 else 1.0
            value += sign * coefficient * standard[parts[-1]]
        assert value == pytest.approx(p["value"], rel=1e-5, abs=1e-9), p["expression"]


def test_two_link_arm_reads_the_textbook_mass_matrix(models):
    """M = [[p1 + 2 (p2 cos q2 + p4 sin q2), p3 + p2 cos q2 + p4 sin q2], [·, p3]] up to the
    symbols' order, scale and sign; the sin q2 parameter (the elbow's first moment across
    the link) is 0 in value, its centre of mass lying on the link's line."""
    answer = equations_answer(derive_equations(models["planar_arm"], form="parametric"))
    assert len(answer["parameters"]) == 6  # 4 in M, 2 more in g
    names = _names(2, 6)
    q2 = names["q2"]
    M = [[sp.sympify(e, locals=names) for e in row] for row in answer["mass_matrix"]["expressions"]]
    assert sp.expand(M[0][1] - M[1][0]) == 0

    def single_symbol(expr):
        (symbol,) = expr.free_symbols
        assert sp.expand(expr - expr.coeff(symbol) * symbol) == 0 and expr.coeff(symbol).is_number
        return symbol

    p3 = single_symbol(M[1][1])
    coupling = sp.expand(M[0][1] - M[1][1])  # p2 cos q2 + p4 sin q2, up to scale and sign
    cos_part, sin_part = coupling.coeff(sp.cos(q2)), coupling.coeff(sp.sin(q2))
    assert sp.expand(coupling - cos_part * sp.cos(q2) - sin_part * sp.sin(q2)) == 0
    p2, p4 = single_symbol(cos_part), single_symbol(sin_part)
    p1 = single_symbol(sp.expand(M[0][0] - 2 * coupling))
    assert len({p1, p2, p3, p4}) == 4
    values = {p["symbol"]: p["value"] for p in answer["parameters"]}
    assert values[str(p4)] == 0.0 and values[str(p2)] != 0.0


def _panda_like():
    """The Panda with its last joint and fingers locked: six revolute joints, offsets and
    perpendicular axes of a real arm."""
    from service.registry.reduce import reduced_robot

    robots, _ = load_catalog(["panda"])
    locked = {"panda_joint7": [0.3], "panda_finger_joint1": [0.02], "panda_finger_joint2": [0.02]}
    origin = {"robot": "panda", "locked_joints": locked}
    return reduced_robot(robots["panda"], locked, "panda6", "panda6", origin).model


def _printed_errors(model, answer, states: int) -> tuple[dict, dict]:
    """`_errors`, the text read by the tests' own evaluator (`evaluate_printed`: SymPy is
    too slow for a six-joint arm's exact text)."""
    n = model.nv
    p = {x["symbol"]: x["value"] for x in answer.get("parameters", [])}

    def printed(quantity: str, values: dict) -> np.ndarray:
        texts = answer[quantity]["expressions"]
        flat = np.ravel(np.array(texts, dtype=object))
        return np.array([evaluate_printed(t, values) for t in flat]).reshape(np.shape(texts))

    data = model.createData()
    rng = np.random.default_rng(2)
    worst = dict.fromkeys(BOUNDED, 0.0)
    largest = dict.fromkeys(BOUNDED, 0.0)
    zero = {**p, **{f"q{i + 1}": 0.0 for i in range(n)}, **{f"dq{i + 1}": 0.0 for i in range(n)}}
    offset = 0.0
    if p:
        offset = float(printed("potential_energy", zero)) - pin.computePotentialEnergy(
            model, data, np.zeros(n)
        )
    for _ in range(states):
        q = random_configuration(model, rng)
        v = rng.uniform(-1, 1, n)
        v[0] = 1.0
        values = {**p, **{f"q{i + 1}": float(q[i]) for i in range(n)}}
        values.update({f"dq{i + 1}": float(v[i]) for i in range(n)})
        reference = _pinocchio(model, data, q, v)
        reference["potential_energy"] = reference["potential_energy"] + offset
        for quantity in BOUNDED:
            error = float(np.abs(printed(quantity, values) - reference[quantity]).max())
            worst[quantity] = max(worst[quantity], error)
            largest[quantity] = max(largest[quantity], float(np.abs(reference[quantity]).max()))
    return worst, largest


# Pinocchio's numbers and the double-precision evaluation of the text carry their own rounding
# (a few ulps of the quantity): the bound is |printed − exact|, the comparison allows 16 ulps
ROUNDING = 16 * np.finfo(float).eps


@pytest.mark.parametrize("name", ["ur5", "panda6", "skewed4", "skewed4b"])
@pytest.mark.parametrize("form", ["numeric", "parametric"])
def test_the_accuracy_bound_holds_against_pinocchio_in_both_forms(models, name, form):
    """`accuracy.max_abs_error` bounds |printed − Pinocchio| (up to rounding) for every
    quantity, in the readable (default) and the exact printing, with the parametric form's
    parameters substituted; the UR5's 4.9e-12 rad tilts included."""
    model = {
        "ur5": lambda: models["ur5"],
        "panda6": _panda_like,
        "skewed4": lambda: pin.buildModelFromXML(skewed_arm_urdf(4, seed=2)),
        "skewed4b": lambda: pin.buildModelFromXML(skewed_arm_urdf(4, seed=5)),
    }[name]()
    eq = derive_equations(model, form=form)
    for digits, tolerance in ((6, 1e-9), (17, 0.0)):
        answer = equations_answer(eq, digits, tolerance)
        worst, largest = _printed_errors(model, answer, states=4)
        for quantity in BOUNDED:
            bound = answer["accuracy"]["max_abs_error"][quantity]
            # (U of the parametric form up to a constant: the bound at the state and at q = 0)
            times = 2 if form == "parametric" and quantity == "potential_energy" else 1
            allowed = times * bound + ROUNDING * max(1.0, largest[quantity])
            assert worst[quantity] <= allowed, (digits, quantity, worst[quantity], bound)
