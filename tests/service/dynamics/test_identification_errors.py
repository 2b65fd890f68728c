"""Bad input to identification: domain errors with the contract's codes and clear details."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.dynamics.identification import identify
from service.errors import (
    DimensionMismatch,
    InvalidConfiguration,
    InvalidInput,
    UnknownFrame,
    UnsupportedModel,
)
from service.registry.catalog import load_catalog
from service.registry.robot import Robot
from tests.service.dynamics.identification_logs import synthetic_log


@pytest.fixture(scope="module")
def ur5():
    return load_catalog(["ur5"])[0]["ur5"]


@pytest.fixture(scope="module")
def log(ur5):
    return synthetic_log(ur5.model, seed=1, duration=4.0, rate=100.0, noise=0.01)


def test_widths(ur5, log):
    with pytest.raises(DimensionMismatch, match="each row of q must have 6 entries"):
        identify(ur5, log.t, log.q[:, :5], log.tau)
    with pytest.raises(DimensionMismatch, match="each row of tau must have 6 entries"):
        identify(ur5, log.t, log.q, log.tau[:, :4])
    with pytest.raises(DimensionMismatch, match="each row of v must have 6 entries"):
        identify(ur5, log.t, log.q, log.tau, v=log.v[:, 1:])
    with pytest.raises(DimensionMismatch, match="tau has 399 rows; t has 400 samples"):
        identify(ur5, log.t, log.q, log.tau[:-1])
    with pytest.raises(InvalidInput, match="t must be 1-D"):
        identify(ur5, log.q, log.q, log.tau)


def test_time_must_increase(ur5, log):
    t = log.t.copy()
    t[10] = t[9]
    with pytest.raises(InvalidInput, match=r"strictly increasing; t\[10\] ≤ t\[9\]"):
        identify(ur5, t, log.q, log.tau)


@pytest.mark.parametrize("field", ["t", "q", "tau", "v"])
def test_non_finite_numbers(ur5, log, field):
    arrays = {"t": log.t.copy(), "q": log.q.copy(), "tau": log.tau.copy(), "v": log.v.copy()}
    arrays[field].flat[7] = np.nan
    with pytest.raises(InvalidInput, match=f"{field} contains a non-finite number"):
        identify(ur5, arrays["t"], arrays["q"], arrays["tau"], v=arrays["v"], a=log.a)


def test_too_few_samples_says_how_many(ur5, log):
    with pytest.raises(InvalidInput) as raised:
        identify(ur5, log.t[:60], log.q[:60], log.tau[:60])
    detail = raised.value.detail
    assert "the log has 60 samples" in detail and "needs at least" in detail
    needed = int(detail.split("needs at least ")[1].split()[0])
    # enough samples (at the same rate, same motion) then identify
    longer = synthetic_log(
        ur5.model, seed=1, duration=(needed + 20) / 100.0, rate=100.0, noise=0.01
    )
    assert longer.t.size > needed
    identify(ur5, longer.t, longer.q, longer.tau, method="least-squares")
    with pytest.raises(InvalidInput, match="needs at least"):
        identify(ur5, log.t[:20], log.q[:20], log.tau[:20], v=log.v[:20], a=log.a[:20])


def test_a_still_log_does_not_excite_the_parameters(ur5, log):
    q = np.repeat(log.q[:1], log.t.size, axis=0)
    zero = np.zeros_like(log.v)
    with pytest.raises(InvalidInput, match="does not excite every base parameter"):
        identify(ur5, log.t, q, log.tau, v=zero, a=zero, method="least-squares")


def test_options(ur5, log):
    with pytest.raises(InvalidInput, match="friction must be one of"):
        identify(ur5, log.t, log.q, log.tau, friction="stribeck")
    with pytest.raises(InvalidInput, match="method must be one of"):
        identify(ur5, log.t, log.q, log.tau, method="magic")
    with pytest.raises(InvalidInput, match="validation_fraction"):
        identify(ur5, log.t, log.q, log.tau, validation_fraction=0.0)
    with pytest.raises(InvalidInput, match="filter_hz must be > 0 and below"):
        identify(ur5, log.t, log.q, log.tau, filter_hz=60.0)
    with pytest.raises(UnknownFrame, match=r"'tool00' is not a frame .*did you mean 'tool0'"):
        identify(ur5, log.t, log.q, log.tau, payload_frame="tool00")


def test_free_flyer_robot_is_unsupported(log):
    model = pin.buildSampleModelHumanoid()
    robot = Robot(
        id="humanoid", name="humanoid", source="upload", root_joint="free-flyer", model=model
    )
    with pytest.raises(UnsupportedModel, match=r"fixed-base robot.*free_flyer"):
        identify(robot, log.t, np.zeros((log.t.size, model.nq)), np.zeros((log.t.size, model.nv)))
    assert UnsupportedModel.code == "unsupported_model"


def test_continuous_joint_needs_unit_cos_sin():
    kinova = load_catalog(["kinova"])[0]["kinova"]
    log = synthetic_log(kinova.model, seed=2, duration=4.0, rate=100.0)
    log.q[3, 0] = 2.0
    with pytest.raises(InvalidConfiguration, match="unit norm"):
        identify(kinova, log.t, log.q, log.tau)


def test_a_log_too_irregular_to_resample(ur5, log):
    t = log.t + 100.0 * (np.arange(log.t.size) // 50)  # a 100 s gap every 50 samples
    with pytest.raises(InvalidInput, match="too irregular to resample"):
        identify(ur5, t, log.q, log.tau)
    identify(ur5, t, log.q, log.tau, v=log.v, a=log.a, method="least-squares")  # as it is


def _gravity_torques(robot, q, noise, seed=0):
    data = robot.model.createData()
    tau = np.array([pin.computeGeneralizedGravity(robot.model, data, qi) for qi in q])
    return tau + np.random.default_rng(seed).normal(0.0, noise, tau.shape) if noise else tau


@pytest.mark.parametrize(("noise", "given"), [(0.05, False), (0.0, False), (0.0, True)])
def test_a_robot_that_does_not_move_is_refused_before_the_fit(ur5, log, noise, given):
    """Constant q, τ = g(q) (+ noise): nothing but gravity at one configuration. With or without
    noise, whatever the method: a validation error naming every joint and its range, before
    any fit (a noiseless fit of such a log is not finite)."""
    q = np.repeat(log.q[:1], log.t.size, axis=0)
    q[:, 0] += 0.004 * np.sin(2 * np.pi * log.t)  # a 1 Hz tremor of 0.008 rad: "still"
    tau = _gravity_torques(ur5, q, noise)
    zero = np.zeros_like(log.v)
    derivatives = {"v": zero, "a": zero} if given else {}
    for method in ("physically-consistent", "least-squares"):
        with pytest.raises(InvalidInput) as raised:
            identify(ur5, log.t, q, tau, method=method, **derivatives)
        detail = raised.value.detail
        assert detail.startswith("the log shows too little motion to identify robot 'ur5'")
        assert "every joint barely moves" in detail and "excite every joint" in detail
        for name in ur5.model.names[1:]:
            assert f"{name} " in detail
        shown = float(detail.split("shoulder_pan_joint ")[1].split()[0])
        assert shown == pytest.approx(0.008, rel=0.1)  # the tremor's range, filtered or not


def test_a_log_where_some_joints_stay_still_is_fitted(ur5, log):
    """Two joints move, four stay still, torques without noise: the physically consistent fit
    is finite (it was not: the posterior's standard deviations lost all precision), predicts
    the held-out torques exactly, and keeps the prior's spread for what the log cannot see;
    least squares names the joints that barely move."""
    moving = [1, 2]
    q = np.repeat(log.q[:1], log.t.size, axis=0)
    v, a = np.zeros_like(log.v), np.zeros_like(log.a)
    q[:, moving], v[:, moving], a[:, moving] = (x[:, moving] for x in (log.q, log.v, log.a))
    model, data = ur5.model, ur5.model.createData()
    tau = np.array([pin.rnea(model, data, q[i], v[i], a[i]) for i in range(log.t.size)])
    result = identify(ur5, log.t, q, tau, v=v, a=a, friction="none")
    std = result.base_parameters["standard_deviation"]
    assert np.isfinite(std).all() and np.isfinite(result.parameters).all()
    assert result.rmse["validation"].max() < 1e-6 * np.abs(tau).max()
    assert std.max() > 1e3 * std.min()  # seen (noiseless: ~0) and unseen (the prior's)
    with pytest.raises(InvalidInput, match=r"does not excite every base parameter") as raised:
        identify(ur5, log.t, q, tau, v=v, a=a, friction="none", method="least-squares")
    still = raised.value.detail.split("barely moving: ")[1]
    assert [n for n in ur5.model.names[1:] if f"{n} " in still] == [
        "shoulder_pan_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    ]


@pytest.mark.parametrize("method", ["least-squares", "physically-consistent"])
@pytest.mark.parametrize(
    ("change", "peak"),
    [
        ({"q": 1e300}, "|q| up to 1e+300"),  # differentiated: v, a ~1e300, v² overflows
        ({"q": 1e150}, "|q| up to 1e+150"),  # the regressor ~1e301: its squares overflow
        ({"v": 1e150, "a": 1e150}, "|v| up to 1.5e+150"),
        ({"tau": 1e300}, "|tau| up to 7.69e+301"),
    ],
)
def test_numbers_too_large_to_fit_are_a_422_naming_them(ur5, log, method, change, peak):
    """The fit sums squares of the regressor (products of velocities and accelerations) and of
    the torques: a log whose squares overflow float64 is refused before the fit, with its
    largest numbers (a LinAlgError or the SDP solver's allocation error otherwise)."""
    arrays = {"t": log.t, "q": log.q, "tau": log.tau}
    if "v" in change:
        arrays.update(v=log.v, a=log.a)
    arrays.update({name: arrays[name] * factor for name, factor in change.items()})
    with pytest.raises(InvalidInput, match="too large to fit in float64") as raised:
        identify(ur5, method=method, **arrays)
    assert peak in raised.value.detail


def test_overflowing_filter_and_counts_are_422s(ur5, log):
    """Samples 1e-322 s apart (a sample rate beyond float64), a cut-off whose normalized
    frequency underflows, a validation fraction so small that the samples it needs are beyond
    counting: each a validation error naming its input."""
    with pytest.raises(InvalidInput, match="t: the log's median sample interval"):
        identify(ur5, log.t * 1e-320, log.q, log.tau)
    with pytest.raises(InvalidInput, match=r"filter_hz: a cut-off of 4\.94e-324 Hz"):
        identify(ur5, log.t, log.q, log.tau, filter_hz=5e-324)
    with pytest.raises(InvalidInput, match="needs at least inf"):
        identify(ur5, log.t, log.q, log.tau, validation_fraction=5e-324)


def test_a_solver_that_fails_to_start_falls_back_and_then_says_so(monkeypatch):
    """SCS raises ValueError ("ScsWork allocation error!") on data it cannot factor: that
    solver failed, the next is tried, and when none solves the fit is a validation error."""
    import cvxpy as cp

    from service.dynamics.identification import fit as fit_module

    tried = []

    def failing(self, solver=None, **kwargs):
        tried.append(solver)
        raise ValueError("ScsWork allocation error!")

    monkeypatch.setattr(cp.Problem, "solve", failing)
    with pytest.raises(InvalidInput, match="physically consistent fit did not converge"):
        fit_module._consistent(np.eye(10), np.ones(10), np.ones(10), np.ones(10), 1)
    assert tried == [cp.CLARABEL, cp.SCS]
