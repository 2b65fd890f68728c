"""Large batches computed off the event loop are stoppable: `run` with `should_stop` computes
them in chunks of states (or whole). The answer must be the one of the batch computed at
once: a minimum over states, per-state options and the state named by an error refer to the
whole request, not to a chunk."""

from __future__ import annotations

import numpy as np
import pytest

from service.dynamics import run
from service.dynamics.quantity import CHUNK_WORK
from service.errors import ComputationStopped, SingularConfiguration
from service.states import States
from tests.helpers import random_state


class Listening:
    """A `should_stop` that never stops and records the progress it is told."""

    def __init__(self) -> None:
        self.reports: list[tuple[int, int, str]] = []

    def __call__(self) -> bool:
        return False

    def report(self, done: int, total: int, unit: str, stage: str | None = None) -> None:
        self.reports.append((done, total, unit))


def _spec(name: str):
    from service.api.quantities import SPECS

    return SPECS[name].quantity


def _batch(robot, n: int, seed: int = 0, **zero: bool) -> States:
    rng = np.random.default_rng(seed)
    q = np.stack([random_state(robot.model, rng)[0] for _ in range(n)])
    arrays = {"q": q}
    for name in zero:
        arrays[name] = rng.normal(size=(n, robot.nv))
    return States(arrays, True)


@pytest.fixture(scope="module")
def ur5(catalog_registry):
    return catalog_registry.get("ur5")


def _more_than_a_chunk(robot) -> int:
    return 3 * CHUNK_WORK // robot.nv + 17


def test_payload_capacity_of_a_large_batch_is_the_whole_batchs(ur5) -> None:
    s = _batch(ur5, _more_than_a_chunk(ur5))
    options = {"frame": "tool0"}
    at_once = run(ur5, _spec("payload-capacity"), s, options)
    stoppable = run(ur5, _spec("payload-capacity"), s, options, Listening())
    assert len(stoppable["limiting_joint"]) == s.count
    np.testing.assert_array_equal(stoppable["mass"], at_once["mass"])
    masses = np.where(
        np.isnan(at_once["mass"].astype(float)), np.inf, at_once["mass"].astype(float)
    )
    assert stoppable["minimum"]["state"] == int(np.argmin(masses))
    assert stoppable["minimum"]["mass"] == pytest.approx(float(masses.min()), rel=0, abs=0)


def test_per_state_external_wrenches_of_a_large_batch_stay_with_their_states(ur5) -> None:
    s = _batch(ur5, _more_than_a_chunk(ur5), v=True, a=True)
    wrenches = np.random.default_rng(1).normal(size=(s.count, 6))
    options = {"external_forces": [{"frame": "tool0", "wrench": wrenches.tolist()}]}
    listening = Listening()
    stoppable = run(ur5, _spec("inverse-dynamics"), s, options, listening)
    for i in (0, s.count // 2, s.count - 1):  # each state alone, with its own wrench
        one = States({k: a[i : i + 1] for k, a in s.arrays.items()}, False)
        alone = run(
            ur5,
            _spec("inverse-dynamics"),
            one,
            {"external_forces": [{"frame": "tool0", "wrench": wrenches[i].tolist()}]},
        )
        np.testing.assert_allclose(stoppable["tau"][i], alone["tau"], rtol=0, atol=1e-12)


def test_a_chunked_batch_reports_its_progress_in_states(ur5) -> None:
    s = _batch(ur5, _more_than_a_chunk(ur5), v=True, a=True)
    listening = Listening()
    chunked = run(ur5, _spec("inverse-dynamics"), s, {}, listening)
    np.testing.assert_array_equal(chunked["tau"], run(ur5, _spec("inverse-dynamics"), s, {})["tau"])
    done = [d for d, total, unit in listening.reports]
    assert len(done) >= 3 and done == sorted(done) and done[0] == 0
    assert all(total == s.count and unit == "state" for _, total, unit in listening.reports)


def test_a_singular_state_is_named_by_its_index_in_the_request(ur5) -> None:
    n = _more_than_a_chunk(ur5)
    bent = np.array([0.3, -1.2, 1.5, -0.6, 1.2, 0.4])  # far from every singularity
    q = bent + np.random.default_rng(2).uniform(-0.05, 0.05, (n, ur5.nq))
    s = States({"q": q}, True)
    singular = n - 5  # in the last chunk
    s.arrays["q"][singular] = 0.0  # the UR5 stretched out: its wrist joints line up
    with pytest.raises(SingularConfiguration, match=f"state {singular}:"):
        run(ur5, _spec("operational-space"), s, {"frame": "tool0"}, Listening())


def test_a_whole_batch_is_stopped_before_it_starts(ur5) -> None:
    s = _batch(ur5, _more_than_a_chunk(ur5))
    with pytest.raises(ComputationStopped):
        run(ur5, _spec("payload-capacity"), s, {"frame": "tool0"}, lambda: True)
