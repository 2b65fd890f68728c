"""What a contact request may cost, and how a long rollout stops: every contact quantity has
a work estimate with all its cost factors, refused over ROBODYN_MAX_WORK before computing;
a diverging contact rollout is a non_finite_result like one without contacts; `should_stop`
is asked at least POLL_S apart and its true answer stops a rollout or a batch at once."""

from __future__ import annotations

import re
import time
from collections.abc import Callable

import numpy as np
import pinocchio as pin
import pytest

from service.dynamics import QUANTITIES, stopping
from service.dynamics.contacts import contact_work
from service.dynamics.simulation import simulate, simulation_work
from service.dynamics.stopping import POLL_S
from service.errors import ComputationStopped
from service.settings import Settings
from service.states import States
from tests.service.api.problems.test_errors import assert_problem
from tests.service.dynamics.contacts.test_quantities import contacts_of

FEET = contacts_of("solo12")
Q_SOLO = [0, 0, 0.235, 0, 0, 0, 1, 0.1, 0.8, -1.6, -0.1, 0.8, -1.6, 0.1, -0.8, 1.6, -0.1, -0.8, 1.6]


@pytest.mark.parametrize(
    "extra",
    [
        {"dt": 1e300},
        {
            "dt": 1e-3,
            "controller": {
                "type": "pd",
                "kp": 1e300,
                "kd": 0.0,
                "q_target": [0, 0, 0.3, 0, 0, 0, 1] + [0.0] * 12,
            },
        },
    ],
)
@pytest.mark.parametrize("contacts", [None, FEET])
def test_a_diverging_simulation_is_a_non_finite_result_with_or_without_contacts(
    api, extra, contacts
):
    """dt = 1e300 or kp = 1e300: the state overflows; with contacts as without, the answer
    says the simulation diverged (not a singular contact set with advice to add damping)."""
    body = {"q": Q_SOLO, "v": [0.0] * 18, "steps": 20, "integrator": "rk4", **extra}
    if contacts is not None:
        body["contacts"] = contacts
    problem = assert_problem(
        api.post("/v1/robots/solo12/simulate", json=body), 422, "non_finite_result"
    )
    assert "diverged" in problem["detail"] and "damping" not in problem["detail"]


def _many(robot, count: int) -> list[dict[str, str]]:
    names = [
        f.name for f in robot.model.frames if f.type == pin.FrameType.BODY and f.parentJoint > 1
    ]
    return [{"frame": names[i % len(names)], "type": "6d"} for i in range(count)]


def test_the_work_estimate_counts_every_cost_factor(catalog_registry):
    """Per state: more contacts, 6d rather than point, damping (its iterations) each cost
    more; simulate multiplies by steps and integrator stages, and the controller's
    compensation adds to each evaluation."""
    r = catalog_registry.catalog["talos"]
    one = States({"q": r.default_configuration[None]}, False)
    many = States({"q": np.repeat(r.default_configuration[None], 10, 0)}, True)

    def work(contacts, damping=0.0, s=one):
        return contact_work(r, s, {"contacts": contacts, "damping": damping})

    point = [{"frame": c["frame"], "type": "point"} for c in contacts_of("talos")]
    assert work(point) < work(contacts_of("talos")) < work(_many(r, 16)) < work(_many(r, 64))
    assert work(contacts_of("talos"), 1e-6) > 2 * work(contacts_of("talos"))
    assert work(contacts_of("talos"), s=many) == pytest.approx(
        10 * work(contacts_of("talos")), rel=1e-2
    )
    base = {"steps": 100, "integrator": "semi-implicit-euler", "contacts": contacts_of("talos")}
    euler = simulation_work(r, one, base)
    assert simulation_work(r, one, {**base, "integrator": "rk4"}) == pytest.approx(
        4 * euler, rel=1e-2
    )
    assert simulation_work(r, one, {**base, "steps": 200}) == pytest.approx(2 * euler, rel=1e-2)
    assert simulation_work(r, one, {**base, "controller": {"type": "pd"}}) > euler
    assert simulation_work(r, one, {**base, "damping": 1e-6}) > 2 * euler
    assert (
        simulation_work(r, one, {k: v for k, v in base.items() if k != "contacts"})
        == 100 * r.nv
        < euler
    )
    for quantity in (
        "contact-dynamics",
        "contact-inverse-dynamics",
        "impulse-dynamics",
        "simulate",
    ):
        assert QUANTITIES[quantity].work is not None
        assert "max_work" in QUANTITIES[quantity].settings


def test_a_contact_heavy_simulation_is_refused_before_computing(api, catalog_registry):
    """64 6d contacts with damping and 100,000 RK4 steps (admitted by the plain simulation
    limits: about an hour of computing): a 422 naming ROBODYN_MAX_WORK, at once."""
    r = catalog_registry.catalog["talos"]
    body = {
        "q": r.default_configuration.tolist(),
        "v": [0.0] * r.nv,
        "dt": 1e-3,
        "steps": 100_000,
        "integrator": "rk4",
        "contacts": _many(r, 64),
        "damping": 0.1,
    }
    started = time.perf_counter()
    problem = assert_problem(
        api.post("/v1/robots/talos/simulate", json=body), 422, "validation_error"
    )
    assert time.perf_counter() - started < 2.0
    assert "ROBODYN_MAX_WORK" in problem["detail"]
    assert problem["max_work"] == Settings().max_work and problem["work"] > problem["max_work"]


@pytest.mark.parametrize(
    "quantity", ["contact-dynamics", "contact-inverse-dynamics", "impulse-dynamics"]
)
def test_a_contact_heavy_batch_is_refused_before_computing(api, catalog_registry, quantity):
    """A batch of 2,000 Talos states with 64 damped 6d contacts (~20 s of computing) is a
    422 naming the limit; a small batch of the same passes the check."""
    r = catalog_registry.catalog["talos"]
    n = 2_000
    q = np.repeat(r.default_configuration[None], n, 0).tolist()
    zero = [[0.0] * r.nv] * n
    body = {"q": q, "v": zero, "tau": zero, "a": zero, "contacts": _many(r, 64), "damping": 0.1}
    inputs = QUANTITIES[quantity].inputs
    body = {k: v for k, v in body.items() if k in (*inputs, "contacts", "damping")}
    problem = assert_problem(
        api.post(f"/v1/robots/talos/{quantity}", json=body), 422, "validation_error"
    )
    assert "ROBODYN_MAX_WORK" in problem["detail"] and "2000 states" in problem["detail"]


def test_the_limit_is_a_setting(small_app_factory):
    """ROBODYN_MAX_WORK applies to every contact route: with a tiny limit a single Talos
    stand is refused, without contacts simulate is not concerned."""
    api = small_app_factory(catalog="talos", max_work=100)
    info = api.get("/v1/robots/talos").json()
    q, zero = info["default_configuration"], [0.0] * info["nv"]
    soles = contacts_of("talos")
    for quantity, body in (
        ("contact-dynamics", {"q": q, "v": zero, "tau": zero, "contacts": soles}),
        ("simulate", {"q": q, "v": zero, "dt": 1e-3, "steps": 10, "contacts": soles}),
    ):
        problem = assert_problem(
            api.post(f"/v1/robots/talos/{quantity}", json=body), 422, "validation_error"
        )
        assert problem["max_work"] == 100
    plain = api.post("/v1/robots/talos/simulate", json={"q": q, "v": zero, "dt": 1e-3, "steps": 10})
    assert plain.status_code == 200, plain.text


def _solo_rollout(catalog_registry, steps: int, **kw):
    r = catalog_registry.catalog["solo12"]
    s = States({"q": np.array(Q_SOLO, dtype=float)[None], "v": np.zeros((1, r.nv))}, False)
    settings = Settings()  # the step limits, passed as the endpoint passes them
    return simulate(
        r,
        s,
        dt=1e-3,
        steps=steps,
        contacts=FEET,
        integrator="rk4",
        max_simulation_steps=settings.max_simulation_steps,
        max_simulation_work=settings.max_simulation_work,
        **kw,
    )


def _asked_until(answers_true_at: int) -> tuple[list[float], list[float], Callable[[], bool]]:
    """A `should_stop` answering true at its `answers_true_at`-th ask, and the monotonic
    times (s) at which each ask started and returned."""
    started: list[float] = []
    returned: list[float] = []

    def should_stop() -> bool:
        started.append(time.monotonic())
        answer = len(started) == answers_true_at
        returned.append(time.monotonic())
        return answer

    return started, returned, should_stop


class _AlwaysFalse:
    """A `should_stop` that always answers false and counts how often it was asked."""

    def __init__(self) -> None:
        self.count = 0

    def __call__(self) -> bool:
        self.count += 1
        return False


def _assert_asked_poll_s_apart(started: list[float], returned: list[float]) -> None:
    """Each ask starts at least POLL_S after the previous one returned (the stopper reads
    the clock after an ask: a rule, not a measurement; 1e-9 s for the float subtraction)."""
    gaps = np.array(started[1:]) - np.array(returned[:-1])
    assert gaps.min() >= POLL_S - 1e-9, gaps


def test_should_stop_stops_a_rollout_at_once(catalog_registry, monkeypatch):
    """A rollout asks `should_stop` at most every POLL_S of computing: answering true stops
    it with ComputationStopped (a 503 `overloaded` code) at that ask, before the next step;
    answering false changes nothing."""
    steps = 100_000  # RK4 with four contacts: about a minute of computing
    started, returned, should_stop = _asked_until(3)
    with pytest.raises(ComputationStopped) as stopped:
        _solo_rollout(catalog_registry, steps, should_stop=should_stop)
    raised = time.monotonic()
    assert stopped.value.code == "overloaded"
    at_step = int(re.search(r"stopped at step (\d+)", stopped.value.detail).group(1))
    assert 0 < at_step < steps
    assert len(started) == 3  # the true answer was the last ask: nothing computed after it
    _assert_asked_poll_s_apart(started, returned)
    # Microseconds from the true answer to the raise; the bound is far from any machine's
    # scheduling noise, and far below the minute the remaining steps would take.
    assert raised - returned[-1] < 5.0
    monkeypatch.setattr(stopping, "POLL_S", 0.0)  # asked at every step
    asked_false = _AlwaysFalse()
    full = _solo_rollout(catalog_registry, 50, should_stop=asked_false)
    assert asked_false.count >= 50
    plain = _solo_rollout(catalog_registry, 50)
    for name, value in plain.items():
        np.testing.assert_array_equal(full[name], value)


@pytest.mark.parametrize(
    "quantity", ["contact-dynamics", "contact-inverse-dynamics", "impulse-dynamics"]
)
def test_should_stop_stops_a_contact_batch(catalog_registry, quantity, monkeypatch):
    """The contact quantities ask `should_stop` between states of a batch the same way:
    true stops the batch at that ask; false everywhere gives the answer computed without
    `should_stop`."""
    r = catalog_registry.catalog["talos"]
    n = 20_000  # seconds of computing
    q = np.repeat(r.default_configuration[None], n, 0)
    zero = np.zeros((n, r.nv))
    arrays = {"q": q, "v": zero, "tau": zero, "a": zero}
    spec = QUANTITIES[quantity]
    s = States({k: arrays[k] for k in spec.inputs}, True)
    started, returned, should_stop = _asked_until(2)
    with pytest.raises(ComputationStopped) as stopped:
        spec.compute(r, s, contacts=contacts_of("talos"), should_stop=should_stop)
    raised = time.monotonic()
    assert quantity in stopped.value.detail
    at_state = int(re.search(r"stopped at state (\d+)", stopped.value.detail).group(1))
    assert 0 < at_state < n
    assert len(started) == 2
    _assert_asked_poll_s_apart(started, returned)
    assert raised - returned[-1] < 5.0  # microseconds; see the rollout's test
    monkeypatch.setattr(stopping, "POLL_S", 0.0)  # asked at every state
    rng = np.random.default_rng(0)
    moving = {k: 0.1 * rng.normal(size=(50, r.nv)) for k in ("v", "tau", "a")}
    few = States({k: moving.get(k, q[:50]) for k in spec.inputs}, True)
    asked_false = _AlwaysFalse()
    full = spec.compute(r, few, contacts=contacts_of("talos"), should_stop=asked_false)
    assert asked_false.count >= 50
    plain = spec.compute(r, few, contacts=contacts_of("talos"))
    for name, value in plain.items():
        np.testing.assert_array_equal(full[name], value)


@pytest.mark.slow
def test_the_largest_admitted_contact_simulation_takes_seconds_not_hours(catalog_registry):
    """Calibration of the default ROBODYN_MAX_WORK: the longest admitted rollout of Talos
    with 64 damped 6d contacts computes in about 10 s or less on one core."""
    r = catalog_registry.catalog["talos"]
    contacts = _many(r, 64)
    one = States({"q": r.default_configuration[None], "v": np.zeros((1, r.nv))}, False)
    options = {"steps": 1, "integrator": "rk4", "contacts": contacts, "damping": 0.1}
    steps = int(Settings().max_work // simulation_work(r, one, options))
    started = time.perf_counter()
    settings = Settings()
    simulate(
        r,
        one,
        dt=1e-3,
        steps=steps,
        contacts=contacts,
        damping=0.1,
        integrator="rk4",
        max_work=settings.max_work,
        max_simulation_steps=settings.max_simulation_steps,
        max_simulation_work=settings.max_simulation_work,
    )
    assert time.perf_counter() - started < 15.0
