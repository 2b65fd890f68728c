"""The parametric form's standard deviations on a robot made by identification.

The reference is a Monte-Carlo: the same motion logged again and again with fresh Gaussian
noise on the torques, identified each time (least squares), and each p_k evaluated from its
printed expression on the identified standard parameters. The spread of those values is what
the standard deviation must say: with K = 60 logs, the sample standard deviation is within
±(3 / √(2 (K − 1))) ≈ ±28 % of the true one (three of its own standard errors); the test allows
[0.7, 1.4].
"""

from __future__ import annotations

import numpy as np
import pytest

from service.dynamics.equations import derive_equations
from service.dynamics.identification import identify
from service.dynamics.identification.parameters import LAYOUT
from service.registry.catalog import load_catalog
from service.registry.variants import with_parameters
from tests.service.dynamics.identification_logs import synthetic_log

NOISE = 0.05  # N·m
RUNS = 60

# the contract's names of a body's 10 parameters, in identification's order (LAYOUT)
CONTRACT = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")


@pytest.fixture(scope="module")
def arm():
    robots, failures = load_catalog(["planar_arm"])
    assert not failures
    return robots["planar_arm"]


def _value(expression: str, standard: dict[str, float]) -> float:
    """A printed expression ("a.m + 0.425 b.m - c.Izz") on the standard parameters."""
    value = 0.0
    for term in expression.replace(" - ", " + -").split(" + "):
        sign = -1.0 if term.startswith("-") else 1.0
        parts = term.lstrip("-").split(" ")
        coefficient = float(parts[0]) if len(parts) == 2 else 1.0
        value += sign * coefficient * standard[parts[-1]]
    return value


def _standard(robot, pi: np.ndarray) -> dict[str, float]:
    joints = [str(robot.model.names[j]) for j in range(1, robot.model.njoints)]
    assert len(LAYOUT) == len(CONTRACT)
    return {
        f"{joint}.{name}": float(pi[10 * b + i])
        for b, joint in enumerate(joints)
        for i, name in enumerate(CONTRACT)
    }


def test_standard_deviations_match_a_monte_carlo_of_the_identification(arm):
    clean = synthetic_log(arm.model, seed=3, duration=10.0, rate=100.0, noise=0.0)
    rng = np.random.default_rng(11)

    def identified(tau: np.ndarray):
        return identify(arm, clean.t, clean.q, tau, v=clean.v, a=clean.a, method="least-squares")

    first = identified(clean.tau + rng.normal(0.0, NOISE, clean.tau.shape))
    assert first.uncertainty is not None
    model = with_parameters(arm.model, first.parameters)
    parameters = derive_equations(model, form="parametric", uncertainty=first.uncertainty)
    parameters = parameters.parameters
    reported = np.array([p.standard_deviation for p in parameters], dtype=float)
    assert np.isfinite(reported).all() and (reported > 0).all(), reported

    samples = []
    for _ in range(RUNS):
        result = identified(clean.tau + rng.normal(0.0, NOISE, clean.tau.shape))
        standard = _standard(arm, result.parameters)
        samples.append([_value(p.expression, standard) for p in parameters])
    spread = np.std(np.array(samples), axis=0, ddof=1)
    ratio = reported / spread
    assert ((ratio > 0.7) & (ratio < 1.4)).all(), dict(
        zip([p.expression for p in parameters], ratio.round(3), strict=True)
    )


def test_a_parameter_that_is_one_base_parameter_has_its_standard_deviation(arm):
    """Where p_k is one of identification's base parameters (the same expression), its
    standard deviation is identification's own, to rounding: the linear propagation."""
    log = synthetic_log(arm.model, seed=4, duration=10.0, rate=100.0, noise=NOISE)
    result = identify(arm, log.t, log.q, log.tau, v=log.v, a=log.a, method="least-squares")
    model = with_parameters(arm.model, result.parameters)
    eq = derive_equations(model, form="parametric", uncertainty=result.uncertainty)
    base = result.base_parameters
    contract = [
        e.replace(".m_cx", ".mx").replace(".m_cy", ".my").replace(".m_cz", ".mz")
        for e in base["expressions"]
    ]
    matched = 0
    for p in eq.parameters:
        if p.expression in contract:
            k = contract.index(p.expression)
            assert p.standard_deviation == pytest.approx(base["standard_deviation"][k], rel=1e-6)
            matched += 1
    assert matched >= 2, [p.expression for p in eq.parameters]


def test_parameters_the_log_does_not_determine_have_none(arm):
    """The shoulder held still (physically consistent fit: the prior fills in what the log
    does not say): M11's constant p1, which only the shoulder's acceleration shows, has no
    standard deviation; the parameters the elbow's motion determines have a finite one."""
    log = synthetic_log(arm.model, seed=5, duration=10.0, rate=100.0, noise=NOISE)
    q, v, a = log.q.copy(), log.v.copy(), log.a.copy()
    q[:, 0], v[:, 0], a[:, 0] = 0.4, 0.0, 0.0
    import pinocchio as pin

    data = arm.model.createData()
    true_model = with_parameters(arm.model, log.pi)
    tau = np.array([pin.rnea(true_model, data, q[i], v[i], a[i]) for i in range(q.shape[0])])
    tau += np.random.default_rng(6).normal(0.0, NOISE, tau.shape)
    result = identify(arm, log.t, q, tau, v=v, a=a, friction="none")
    model = with_parameters(arm.model, result.parameters)
    eq = derive_equations(model, form="parametric", uncertainty=result.uncertainty)
    deviations = {p.expression: p.standard_deviation for p in eq.parameters}
    assert deviations["shoulder.Iyy + elbow.m + elbow.Iyy"] is None, deviations
    assert deviations["elbow.Iyy"] is not None, deviations
    assert all(d is None or (np.isfinite(d) and d > 0) for d in deviations.values()), deviations


def test_a_robot_not_identified_has_no_standard_deviations(arm):
    eq = derive_equations(arm.model, form="parametric")
    assert [p.as_dict()["standard_deviation"] for p in eq.parameters] == [None] * len(eq.parameters)
