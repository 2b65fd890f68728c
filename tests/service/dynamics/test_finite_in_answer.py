"""A large inverse-dynamics or nonlinear-effects batch leaves the finiteness of v and a to its
answer's check (`Quantity.finite_in_answer`): that holds because a NaN or ±inf in any of them
always reaches the answer of the parallel RNEA (checked here for every velocity coordinate of
every catalog robot), and the request's error is the one the inputs give without the shortcut,
whatever else is wrong with them."""

from __future__ import annotations

import numpy as np
import pytest

from service import state_numbers
from service.api.encoding import binary
from service.dynamics import QUANTITIES, finite_from_answer, parallel
from service.states import States
from tests.helpers import random_state

BAD = (np.nan, np.inf, -np.inf)


def test_only_rnea_batches_without_options_leave_inputs_to_the_answer():
    by_name = QUANTITIES
    assert finite_from_answer(by_name["inverse-dynamics"], {}) == {"v", "a"}
    assert finite_from_answer(by_name["nonlinear-effects"], {}) == {"v"}
    assert finite_from_answer(by_name["inverse-dynamics"], {"payloads": []}) == frozenset()
    for name in ("forward-dynamics", "gravity", "mass-matrix", "coriolis"):
        assert finite_from_answer(by_name[name], {}) == frozenset()


def test_every_non_finite_velocity_or_acceleration_reaches_the_answer(catalog_registry):
    """One state per (coordinate, bad value, input) on each catalog robot, through the
    parallel RNEA the service runs: every such state's answer holds a non-finite number."""
    rng = np.random.default_rng(11)
    for robot_id in catalog_registry.catalog:
        robot = catalog_registry.get(robot_id)
        q, v, a = random_state(robot.model, rng)
        states = []
        for name in ("v", "a"):
            for k in range(robot.nv):
                for bad in BAD:
                    x = {"v": v.copy(), "a": a.copy()}
                    x[name][k] = bad
                    states.append((q, x["v"], x["a"]))
        batch = States(
            {key: np.stack(c) for key, c in zip("qva", zip(*states, strict=True), strict=True)},
            True,
        )
        tau = parallel.inverse_dynamics(robot, batch)["tau"]
        reached = ~np.isfinite(tau).all(axis=1)
        assert reached.all(), f"{robot_id}: states {np.flatnonzero(~reached)[:5]} stayed finite"
        h = parallel.nonlinear_effects(robot, batch)["nonlinear_effects"]
        with_bad_v = np.arange(len(states)) < robot.nv * len(BAD)
        assert (~np.isfinite(h).all(axis=1))[with_bad_v].all(), robot_id


def _talos_batch(robot, n: int = 1200) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(3)
    q, v, a = (
        np.stack(x) for x in zip(*[random_state(robot.model, rng) for _ in range(n)], strict=True)
    )
    return {"q": q, "v": v, "a": a}


def _post(api, inputs: dict[str, np.ndarray], quantity: str = "inverse-dynamics"):
    return api.post(
        f"/v1/robots/talos/{quantity}",
        content=binary.encode(inputs),
        headers={"content-type": binary.BINARY_MEDIA_TYPE, "accept": binary.BINARY_MEDIA_TYPE},
    )


@pytest.mark.parametrize(
    "spoil",
    [
        {"v": (0, 3)},
        {"a": (1199, 37)},
        {"v": (600, 0), "a": (5, 5)},  # v's error first, as the inputs are checked in order
        {"a": (7, 2), "q_norm": 9},  # a's error before the quaternion's
        {"q": (4, 10), "v": (2, 2)},  # q's before v's
        {"q_norm": 9},  # a finite batch that fails otherwise
    ],
)
def test_the_error_is_the_one_the_inputs_give(api, catalog_registry, monkeypatch, spoil):
    """The same status and detail as with every input read before computing
    (`finite_in_answer` emptied), for NaN and ±inf anywhere, alone or with other faults."""
    robot = catalog_registry.get("talos")
    inputs = _talos_batch(robot)
    assert sum(x.size for x in inputs.values()) >= state_numbers.TWO_THREADS_FROM
    for name, where in spoil.items():
        if name == "q_norm":
            inputs["q"][where, 3:7] *= 1.5
        else:
            inputs[name][where] = np.nan if where[0] % 2 else -np.inf
    deferred = _post(api, inputs)
    monkeypatch.setattr(
        "service.dynamics.finite_from_answer", lambda quantity, options: frozenset()
    )
    checked = _post(api, inputs)
    assert deferred.status_code == checked.status_code == 422
    assert deferred.json() == checked.json()
    first = next(iter(spoil))
    expected = "must have unit norm" if first == "q_norm" else f"{first} contains a non-finite"
    assert expected in deferred.json()["detail"]


def test_a_finite_batch_answers_as_before(api, catalog_registry):
    import pinocchio as pin

    robot = catalog_registry.get("talos")
    inputs = _talos_batch(robot, 1000)
    r = _post(api, inputs)
    assert r.status_code == 200, r.text
    tau = binary.decode(r.content)[1]["tau"]
    data = robot.model.createData()
    expected = np.stack(
        [pin.rnea(robot.model, data, *s) for s in zip(*inputs.values(), strict=True)]
    )
    np.testing.assert_array_equal(tau, expected)
