"""The numeric checks of joint-space inputs (`service.states` says what they mean and words
the errors): finiteness, each column's extremes, the norms of unit-norm entries of q; for a
large batch, all of them at once on two threads.

numpy's reductions release the GIL, so two threads check at once: a batch of 10,000 Talos
states (9.2 MB) is read in about half the time, which a co-located client's request waits
for in full (docs/performance.md, "Co-located clients").
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

_SMALL = 4096
# A NaN from all_finite's dot product is its answer, not a mishap worth a warning.
warnings.filterwarnings(
    "ignore", "invalid value encountered in dot", RuntimeWarning, module=__name__
)
_ZEROS = np.zeros(_SMALL)
_ZEROS.flags.writeable = False
TWO_THREADS_FROM = 100_000  # numbers in a request's inputs, checked on two threads from here
_SECOND = ThreadPoolExecutor(max_workers=1, thread_name_prefix="input-checks")


def all_finite(values: np.ndarray) -> bool:
    """Whether every entry of a float64 array is finite (no NaN, no ±inf).

    Small arrays (single states, one matrix) take the dot product with zeros, which is NaN
    exactly when an entry is NaN or infinite (x·0 = 0 for every finite x, so no overflow):
    one call of about 0.5 µs instead of `np.isfinite(values).all()`'s 1.8 µs."""
    if values.size <= _SMALL:
        flat = values.reshape(-1)
        return math.isfinite(flat.dot(_ZEROS[: flat.size]))
    return bool(np.isfinite(values).all())


def first_non_finite(arr: np.ndarray) -> str:
    """Where the first non-finite entry of a 1-D or 2-D array is, and what it is (looked
    for only once the array is known to hold one)."""
    index = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
    value = arr[index]
    if arr.ndim == 2:
        return f"state {index[0]}, entry {index[1]} is {value}"
    return f"entry {index[0]} is {value}"


_ROWS_AT_ONCE = 64


def column_extremes(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The smallest and the largest entry of each column of a C-contiguous (N, n) array (NaN
    where the column holds one). Reduced over blocks of `_ROWS_AT_ONCE` rows seen as one
    long row, then over the blocks' n-wide results: numpy's reduction along axis 0 of a
    narrow array pays a step per row (0.4 ms for (10,000, 39)), over wide rows it runs at
    memory speed."""
    n, width = x.shape
    whole = n - n % _ROWS_AT_ONCE
    if whole == 0 or not x.flags.c_contiguous:
        return x.min(axis=0), x.max(axis=0)
    blocks = x[:whole].reshape(whole // _ROWS_AT_ONCE, _ROWS_AT_ONCE * width)
    smallest = blocks.min(axis=0).reshape(_ROWS_AT_ONCE, width).min(axis=0)
    largest = blocks.max(axis=0).reshape(_ROWS_AT_ONCE, width).max(axis=0)
    if whole < n:
        rest = x[whole:]
        smallest = np.minimum(smallest, rest.min(axis=0))
        largest = np.maximum(largest, rest.max(axis=0))
    return smallest, largest


def unit_norms(q: np.ndarray, start: int, end: int) -> np.ndarray:
    """‖q[:, start:end]‖ of each state (a quaternion or a (cos, sin) pair), (N,)."""
    unit = q[:, start:end]
    with np.errstate(over="ignore"):  # a norm past 1e154 overflows to inf: refused by callers
        # √(Σ x²) by einsum: no temporary of the squares (0.1 ms for 10,000 quaternions,
        # np.linalg.norm 0.3 ms)
        norms: np.ndarray = np.sqrt(np.einsum("ij,ij->i", unit, unit))
    return norms


@dataclass(frozen=True)
class BatchNumbers:
    """What the checks of a large batch need, computed at once: which inputs hold a
    non-finite number, each column's extremes of q (None without q), and the norms of q's
    unit-norm entries by their start (empty when q's width is not `nq`)."""

    non_finite: dict[str, bool]
    q_extremes: tuple[np.ndarray, np.ndarray] | None
    norms: dict[int, np.ndarray]


def batch_numbers(
    inputs: Mapping[str, object],
    nq: int,
    unit_entries: list[tuple[int, int]],
    finite_later: frozenset[str] = frozenset(),
) -> BatchNumbers | None:
    """`BatchNumbers` of a large batch of float64 (N, n) arrays, on this thread and a second
    one; None for anything else (single states, lists, other dtypes, fewer than
    `TWO_THREADS_FROM` numbers), which the callers check one input after the other.
    q's finiteness is read from its columns' extremes (NaN or ±inf where it holds one); the
    inputs named in `finite_later` (not q) are not read for it (flagged finite: the caller
    checks them later)."""
    arrays: dict[str, np.ndarray] = {}
    for name, value in inputs.items():
        if not (isinstance(value, np.ndarray) and value.dtype == np.float64 and value.ndim == 2):
            return None
        arrays[name] = value
    if sum(a.size for a in arrays.values()) < TWO_THREADS_FROM:
        return None
    q = arrays.get("q")
    others = [name for name in arrays if name != "q"]

    def second_thread() -> tuple[dict[str, bool], dict[int, np.ndarray]]:
        flags = {name: name not in finite_later and not all_finite(arrays[name]) for name in others}
        norms = {}
        if q is not None and q.shape[1] == nq:
            norms = {start: unit_norms(q, start, end) for start, end in unit_entries}
        return flags, norms

    pending = _SECOND.submit(second_thread)
    extremes = column_extremes(q) if q is not None and q.shape[0] else None
    flags, norms = pending.result()
    if q is not None:
        flags["q"] = extremes is not None and not (
            all_finite(extremes[0]) and all_finite(extremes[1])
        )
    return BatchNumbers(flags, extremes, norms)
