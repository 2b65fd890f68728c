"""`service.state_numbers.all_finite` agrees with `np.isfinite(x).all()` on every float64
array, small (the dot-with-zeros form) and large, huge finite values included (no overflow)."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from service.errors import InvalidInput
from service.state_numbers import all_finite
from service.states import as_array

ANY_FLOAT = st.floats(allow_nan=True, allow_infinity=True, width=64)


@given(
    hnp.arrays(
        np.float64, hnp.array_shapes(min_dims=0, max_dims=3, max_side=20), elements=ANY_FLOAT
    )
)
def test_agrees_with_isfinite(values: np.ndarray) -> None:
    assert all_finite(values) == bool(np.isfinite(values).all())


@given(
    st.sampled_from([1, 4095, 4096, 4097, 10_000]),
    st.sampled_from([np.nan, np.inf, -np.inf, None]),
    st.data(),
)
def test_one_bad_entry_anywhere_is_found(size: int, bad: float | None, data) -> None:
    values = np.full(size, np.finfo(float).max)  # huge but finite: a sum would overflow
    values[::2] *= -1
    if bad is not None:
        values[data.draw(st.integers(0, size - 1))] = bad
    assert all_finite(values) == (bad is None)
    assert all_finite(values[::3]) == bool(np.isfinite(values[::3]).all())  # not contiguous


def test_a_non_finite_input_is_named_with_its_state_and_entry() -> None:
    """The 422 of a non-finite input names the field, the state and the entry (the first
    one), for a batch and for a single state."""
    batch = np.zeros((10_000, 7))
    batch[6_543, 2] = -np.inf
    batch[9_000, 0] = np.nan
    try:
        as_array("v", batch)
    except InvalidInput as exc:
        assert str(exc).startswith("v contains a non-finite number")
        assert "state 6543, entry 2 is -inf" in str(exc)
    else:
        raise AssertionError("a batch with -inf was accepted")
    try:
        as_array("q", [0.0, float("nan"), 1.0])
    except InvalidInput as exc:
        assert "entry 1 is nan" in str(exc) and "state" not in str(exc)
    else:
        raise AssertionError("a state with NaN was accepted")
