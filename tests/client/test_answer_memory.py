"""The client's memory for large answers (robodyn/answer_memory.py): reused once every array
of an answer is gone, never while one is alive."""

from __future__ import annotations

import gc

import numpy as np
from robodyn import binary
from robodyn.answer_memory import KEPT, SMALLEST, AnswerMemory

SIZE = 3 * 1024 * 1024


def _address(view: memoryview) -> int:
    return int(np.frombuffer(view, dtype=np.uint8).ctypes.data)


def test_an_answers_memory_is_reused_once_its_arrays_are_gone():
    memory = AnswerMemory()
    first = memory.take(SIZE)
    where = _address(first)
    arrays = binary.decode(_filled(first, 1.0))
    del first
    gc.collect()
    other = memory.take(SIZE)
    assert _address(other) != where  # `arrays` still views it: new memory
    del arrays
    again = memory.take(SIZE)  # (the block given back by the collected owner)
    assert _address(again) == where


def test_a_view_kept_by_the_caller_keeps_its_answer_intact():
    memory = AnswerMemory()
    tau = binary.decode(_filled(memory.take(SIZE), 2.0))["tau"]
    kept = tau[10:20, 3]  # a view: its base chain ends at the answer's owner
    expected = kept.copy()
    del tau
    gc.collect()
    for value in (3.0, 4.0):  # later answers of the same size go elsewhere
        later = binary.decode(_filled(memory.take(SIZE), value))["tau"]
        assert np.all(later == value)
        del later
    assert np.array_equal(kept, expected)


def test_at_most_kept_blocks_wait_and_small_answers_are_not_pooled():
    memory = AnswerMemory()
    views = [memory.take(SIZE) for _ in range(KEPT + 3)]
    del views
    gc.collect()
    assert len(memory._free) == KEPT
    small = memory.take(SMALLEST - 1)
    assert isinstance(small.obj, bytearray) and len(small) == SMALLEST - 1
    memory.clear()
    assert len(memory._free) == 0


def _filled(view: memoryview, value: float) -> memoryview:
    """A binary answer of one (rows, 38) tensor `tau` of `value`s written into `view` (its
    whole length: the header is padded to make it fit)."""
    rows = (len(view) - 4096) // (38 * 8)
    content = binary.encode({"tau": np.full((rows, 38), value)})
    assert len(content) <= len(view)
    view[: len(content)] = content
    return view[: len(content)]
