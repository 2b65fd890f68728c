"""`service.state_numbers.column_extremes` gives each column's smallest and largest entry exactly as
numpy's reductions along axis 0, whatever the number of rows (blocks of rows and a rest), NaN
and infinities included; the angle warning that uses it finds a turn outside in any state."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from service.state_numbers import column_extremes
from service.states import angles_far_outside

ANY_FLOAT = st.floats(allow_nan=True, allow_infinity=True, width=64)


@given(
    hnp.arrays(
        np.float64,
        st.tuples(st.integers(1, 300), st.integers(1, 9)),
        elements=ANY_FLOAT,
    )
)
def test_agrees_with_numpy(x: np.ndarray) -> None:
    smallest, largest = column_extremes(x)
    np.testing.assert_array_equal(smallest, x.min(axis=0))
    np.testing.assert_array_equal(largest, x.max(axis=0))


def test_a_single_extreme_anywhere_is_found() -> None:
    rng = np.random.default_rng(3)
    x = rng.uniform(-1, 1, (10_000, 39))
    for row in (0, 63, 64, 9_983, 9_999):  # in a block, at a block's edge, in the rest
        y = x.copy()
        y[row, 17] = 50.0
        y[row, 5] = -50.0
        smallest, largest = column_extremes(y)
        assert largest[17] == 50.0 and smallest[5] == -50.0
        np.testing.assert_array_equal(column_extremes(y[:, ::2])[0], y[:, ::2].min(axis=0))


def test_an_angle_a_turn_outside_is_warned_in_any_state(catalog_registry) -> None:
    robot = catalog_registry.get("ur5")
    q = np.zeros((1_000, robot.nq))
    assert angles_far_outside(robot, q) is None
    _, index, _, upper = robot.angle_ranges
    assert index.size  # the UR5's six revolute joints have finite ranges
    for state in (0, 640, 999):
        bent = q.copy()
        bent[state, index[0]] = upper[0] + 2 * np.pi + 0.5
        warning = angles_far_outside(robot, bent)
        assert warning is not None and warning.startswith(f"state {state}: q[{index[0]}]")
