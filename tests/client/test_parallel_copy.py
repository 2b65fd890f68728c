"""`robodyn.parallel_copy`: bodies and answers of megabytes copied on two threads arrive byte
for byte, wherever the halves split the parts, and a forked child copies with its own
thread."""

from __future__ import annotations

import multiprocessing

import numpy as np
import pytest
from robodyn import parallel_copy

BIG = parallel_copy.TWO_THREADS_FROM


@pytest.mark.parametrize(
    "sizes",
    [
        [10],  # one thread
        [8, BIG // 2 - 1, 3, BIG // 2 + 17],  # two: the half falls inside a part
        [BIG // 2, BIG // 2],  # two: the half falls between parts
        [1, 0, 5 * BIG + 3],  # two: one part split, an empty part
    ],
)
def test_the_parts_arrive_one_after_the_other(sizes: list[int]):
    rng = np.random.default_rng(len(sizes))
    parts = [memoryview(rng.integers(0, 256, n, dtype=np.uint8).tobytes()) for n in sizes]
    total = sum(sizes)
    destination = np.full(total + 64, 7, dtype=np.uint8)
    parallel_copy.copy_into(destination, parts)
    expected = np.frombuffer(b"".join(parts), dtype=np.uint8)
    assert np.array_equal(destination[:total], expected)
    assert (destination[total:] == 7).all()  # nothing written past the parts


def _copy_in_child() -> None:
    source = np.arange(3 * BIG, dtype=np.uint8)
    destination = np.zeros_like(source)
    parallel_copy.copy_into(destination, [source.data])
    assert np.array_equal(source, destination)


def test_a_forked_child_copies_with_a_thread_of_its_own():
    """The parent's helper thread does not run in a forked child: the child starts its own
    (a copy waiting for the parent's would never end)."""
    _copy_in_child()  # the parent's helper thread exists
    child = multiprocessing.get_context("fork").Process(target=_copy_in_child)
    child.start()
    child.join(60)
    if child.is_alive():
        child.kill()
        child.join()
    assert child.exitcode == 0
