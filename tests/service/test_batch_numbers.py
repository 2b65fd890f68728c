"""A large batch's inputs are checked on two threads (`service.state_numbers.batch_numbers`)
with the same errors, in the same order, and the same warnings as one input after the other."""

from __future__ import annotations

import numpy as np
import pytest

from service import state_numbers
from service.errors import InvalidConfiguration, InvalidInput
from service.states import prepare

N = 3001  # states: not a multiple of the 64 rows `column_extremes` reduces at once


def _talos_batch(robot) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(7)
    q = np.tile(robot.neutral_q if hasattr(robot, "neutral_q") else np.zeros(robot.nq), (N, 1))
    q[:, 7:] = rng.uniform(-0.5, 0.5, size=(N, robot.nq - 7))
    q[:, 3:7] = rng.normal(size=(N, 4))
    q[:, 3:7] /= np.linalg.norm(q[:, 3:7], axis=1, keepdims=True)
    return {
        "q": q,
        "v": rng.normal(size=(N, robot.nv)),
        "a": rng.normal(size=(N, robot.nv)),
    }


def _both_ways(robot, inputs, monkeypatch) -> list[tuple[type, str] | tuple[str, ...]]:
    """What `prepare` gives for `inputs` on two threads, then one input after the other."""
    outcomes = []
    for threshold in (state_numbers.TWO_THREADS_FROM, 10**15):
        monkeypatch.setattr(state_numbers, "TWO_THREADS_FROM", threshold)
        try:
            states = prepare(robot, {k: v.copy() for k, v in inputs.items()}, 10**6)
        except (InvalidInput, InvalidConfiguration) as exc:
            outcomes.append((type(exc), str(exc)))
        else:
            outcomes.append(states.warnings)
    return outcomes


@pytest.mark.parametrize("name", ["q", "v", "a"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("row", [0, 1234, N - 1])
def test_a_non_finite_number_is_named_alike(catalog_registry, monkeypatch, name, bad, row):
    robot = catalog_registry.get("talos")
    inputs = _talos_batch(robot)
    column = inputs[name].shape[1] - 1 if row % 2 else 5
    inputs[name][row, column] = bad
    threads, serial = _both_ways(robot, inputs, monkeypatch)
    assert threads == serial
    assert threads[0] is InvalidInput
    assert f"{name} contains a non-finite number" in threads[1]
    assert f"state {row}, entry {column} is {bad}" in threads[1]


def test_the_first_input_in_order_is_named_and_configurations_are_checked(
    catalog_registry, monkeypatch
):
    robot = catalog_registry.get("talos")
    inputs = _talos_batch(robot)
    inputs["v"][10, 0] = np.nan
    inputs["q"][2000, 8] = np.inf
    threads, serial = _both_ways(robot, inputs, monkeypatch)
    assert threads == serial and threads[1].startswith("q contains")
    inputs = _talos_batch(robot)
    inputs["q"][N - 1, 3:7] *= 1.001  # a quaternion of norm 1.001 in the last state
    threads, serial = _both_ways(robot, inputs, monkeypatch)
    assert threads == serial and threads[0] is InvalidConfiguration
    assert f"state {N - 1}: q[3:7]" in threads[1]


def test_warnings_and_arrays_are_those_of_one_input_after_the_other(catalog_registry, monkeypatch):
    robot = catalog_registry.get("talos")
    inputs = _talos_batch(robot)
    assert _both_ways(robot, inputs, monkeypatch) == [(), ()]
    inputs["q"][N - 1, 20] = 40.0  # rad: a whole turn and more outside the joint's range
    threads, serial = _both_ways(robot, inputs, monkeypatch)
    assert threads == serial and len(threads) == 1 and f"state {N - 1}: q[20]" in threads[0]
    states = prepare(robot, inputs, 10**6)  # (checked in place: no copy of the inputs)
    assert all(states[k] is inputs[k] for k in ("v", "a"))
