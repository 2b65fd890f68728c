"""`run` with a `split`: a state-by-state quantity's batch filled slice by slice, in any order
and by anyone, is the batch computed at once, and a stoppable batch is cut into chunks
`split.processes` times larger (each process computes about one chunk's work)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.dynamics import QUANTITIES, run
from service.dynamics.quantity import CHUNK_WORK
from service.states import States
from tests.helpers import random_configuration


class Reversed:
    """A split that fills the batch in slices of 97 states, last slice first, and records the
    batch sizes it was given."""

    processes = 3

    def __init__(self) -> None:
        self.batches: list[int] = []

    def __call__(self, robot, quantity, s, out):
        self.batches.append(s.count)
        n = s.count
        for start in reversed(range(0, n, 97)):
            rows = slice(start, min(n, start + 97))
            part = States({k: a[rows] for k, a in s.arrays.items()}, True)
            quantity.state_by_state.fill(robot, part, {k: a[rows] for k, a in out.items()})


def _states(model, n: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(11)
    return {
        "q": np.stack([random_configuration(model, rng) for _ in range(n)]),
        "v": rng.normal(size=(n, model.nv)),
    }


@pytest.mark.parametrize("name", ["mass-matrix", "coriolis"])
def test_a_batch_filled_in_slices_is_the_batch_computed_at_once(catalog_registry, name):
    robot = catalog_registry.get("talos")
    quantity = QUANTITIES[name]
    s = _states(robot.model, 500)
    states = States({k: s[k] for k in quantity.inputs}, True)
    split = Reversed()
    got = run(robot, quantity, states, {}, split=split)
    assert split.batches == [500]
    whole = run(robot, quantity, states, {})
    assert got.keys() == whole.keys()
    for key in whole:
        assert np.array_equal(got[key], whole[key]), key
    data = robot.model.createData()
    if name == "mass-matrix":
        expected = np.stack([pin.crba(robot.model, data, q) for q in s["q"]])
        assert np.array_equal(got["mass_matrix"], expected)
    else:
        C = [
            pin.computeCoriolisMatrix(robot.model, data, q, v)
            for q, v in zip(s["q"], s["v"], strict=True)
        ]
        assert np.array_equal(got["coriolis_matrix"], np.stack(C))


def test_a_stoppable_split_batch_is_cut_in_larger_chunks(catalog_registry):
    robot = catalog_registry.get("talos")
    quantity = QUANTITIES["mass-matrix"]
    chunk = CHUNK_WORK // robot.nv
    n = 2 * Reversed.processes * chunk + 5
    states = States({"q": _states(robot.model, n)["q"]}, True)
    split = Reversed()
    got = run(robot, quantity, states, {}, lambda: False, split)
    assert split.batches == [Reversed.processes * chunk] * 2 + [5]
    assert np.array_equal(got["mass_matrix"], run(robot, quantity, states, {})["mass_matrix"])


def test_quantities_with_options_are_not_split(catalog_registry):
    robot = catalog_registry.get("ur5")
    quantity = QUANTITIES["inverse-dynamics"]  # not state by state: computed as before
    assert quantity.state_by_state is None
    s = _states(robot.model, 300)
    states = States({"q": s["q"], "v": s["v"], "a": s["v"]}, True)
    split = Reversed()
    run(robot, quantity, states, {}, split=split)
    assert split.batches == []
