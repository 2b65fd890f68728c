"""Batches on every core (`service.dynamics.parallel`) are computed in native calls of about a
millisecond, asking the request's `should_stop` before each; when it allows holding the
interpreter (`may_hold`: nothing else to serve, the deadline far) the rest is one call. Either
way the answer is Pinocchio's state by state, and a stop between calls still stops."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.dynamics import answer_arrays, parallel, run
from service.errors import ComputationStopped
from service.states import States
from tests.helpers import random_state


class Asking:
    """A `should_stop` that never stops, records progress and what it was asked to hold,
    and allows holding as `allow` says."""

    def __init__(self, allow: bool) -> None:
        self.allow = allow
        self.reports: list[int] = []
        self.held: list[float] = []

    def __call__(self) -> bool:
        return False

    def report(self, done: int, total: int, unit: str, stage: str | None = None) -> None:
        self.reports.append(done)

    def may_hold(self, seconds: float) -> bool:
        self.held.append(seconds)
        return self.allow


def _spec(name: str):
    from service.api.quantities import SPECS

    return SPECS[name].quantity


@pytest.fixture(scope="module")
def talos(catalog_registry):
    return catalog_registry.get("talos")


@pytest.fixture(scope="module")
def batch(talos) -> States:
    """Four chunks' worth of Talos states and more."""
    n = 4 * max(256, parallel.CHUNK_WORK // talos.nv) + 11
    rng = np.random.default_rng(5)
    states = [random_state(talos.model, rng) for _ in range(n)]
    q, v, a = (np.stack(x) for x in zip(*states, strict=True))
    return States({"q": q, "v": v, "a": a}, True)


def _rnea_state_by_state(robot, s: States) -> np.ndarray:
    data = robot.model.createData()
    return np.stack(
        [
            np.array(pin.rnea(robot.model, data, s["q"][i], s["v"][i], s["a"][i]))
            for i in range(s.count)
        ]
    )


@pytest.mark.parametrize("allow", [True, False])
def test_inverse_dynamics_is_rnea_state_by_state_whether_held_or_chunked(talos, batch, allow):
    asking = Asking(allow)
    tau = run(talos, _spec("inverse-dynamics"), batch, {}, asking)["tau"]
    np.testing.assert_array_equal(tau, _rnea_state_by_state(talos, batch))
    chunk = max(256, parallel.CHUNK_WORK // talos.nv)
    if allow:  # one chunk, then the rest in one call
        assert asking.reports == [0, chunk]
    else:  # every chunk
        assert asking.reports == list(range(0, batch.count, chunk))
    # asked with the time the rest would take at the measured rate: positive, finite
    assert asking.held and all(0 < s < 60 for s in asking.held)


def test_a_batch_without_may_hold_is_computed_in_chunks(talos, batch):
    """A `should_stop` without `may_hold` (a plain callable) never lets a call run long."""
    reports: list[int] = []

    class Plain:
        def __call__(self) -> bool:
            return False

        def report(self, done: int, total: int, unit: str, stage: str | None = None) -> None:
            reports.append(done)

    run(talos, _spec("gravity"), States({"q": batch["q"]}, True), {}, Plain())
    chunk = max(256, parallel.CHUNK_WORK // talos.nv)
    assert reports == list(range(0, batch.count, chunk))


def test_a_parallel_batch_stops_between_its_calls(talos, batch):
    """A `should_stop` that says stop after the second chunk (a deadline passed, a client
    gone) stops the batch there, named by the state it reached."""
    asked = 0

    def stop_at_the_third_question() -> bool:
        nonlocal asked
        asked += 1
        return asked >= 3

    chunk = max(256, parallel.CHUNK_WORK // talos.nv)
    with pytest.raises(ComputationStopped, match=f"stopped at state {2 * chunk} of {batch.count}"):
        run(talos, _spec("forward-dynamics"), _forward(batch), {}, stop_at_the_third_question)


def _forward(s: States) -> States:
    return States({"q": s["q"], "v": s["v"], "tau": s["a"]}, True)


def test_a_batch_is_computed_into_the_arrays_its_request_provides(talos, batch):
    """Under `answer_arrays.provided_by`, the answer is computed into the provided array (a
    co-located client's answer file), Pinocchio's state by state; without a provider, or
    when it has none to give, into new memory."""
    provided: list[np.ndarray] = []

    def provide(shapes):
        arrays = {name: np.full(shape, np.nan) for name, shape in shapes.items()}
        provided.extend(arrays.values())
        return arrays

    with answer_arrays.provided_by(provide):
        tau = run(talos, _spec("inverse-dynamics"), batch, {}, Asking(True))["tau"]
    assert len(provided) == 1 and tau is provided[0]
    np.testing.assert_array_equal(tau, _rnea_state_by_state(talos, batch))
    with answer_arrays.provided_by(lambda shapes: None):
        again = run(talos, _spec("inverse-dynamics"), batch, {}, Asking(True))["tau"]
    assert again is not tau
    np.testing.assert_array_equal(again, tau)
