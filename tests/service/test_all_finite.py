"""`service.states.all_finite` agrees with `np.isfinite(x).all()` on every float64 array, small
(the dot-with-zeros form) and large, huge finite values included (no overflow)."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from service.states import all_finite

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
