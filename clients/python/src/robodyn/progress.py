"""Progress of long work: batches sent in chunks of states, simulations in chunks of steps,
and single computations that report their own progress.

`progress` is a callable `(done, total)` or True for a `tqdm` bar (`pip install tqdm`).

- A batch or a simulation is split into chunks only when progress is asked for; the callable
  is called after each chunk with the states (or steps) done so far — in order, the last call
  with done == total — and the answer is the same, bit for bit, as in one request.
- A computation that is one request (a trajectory check, a retiming, an identification: its
  rows are one motion, path or log) is sent once, asking the server for its progress stream;
  the callable is called with the server's counts as they come (evaluated points of a check,
  stages of an identification; a tqdm bar also shows the stage) and a last time with
  done == total once the answer is in. A computation too short to report reports nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Mapping
from dataclasses import dataclass
from typing import Any, Generic, TypeVar, Union

from robodyn.errors import InputError

ProgressCallback = Callable[[int, int], object]
"""Called as `callback(done, total)` after each chunk."""
Progress = Union[ProgressCallback, bool, None]  # noqa: UP007 (a runtime alias on Python 3.10)

CHUNK_STATES = 2000
"""States per request of a batch sent in chunks (with progress)."""
CHUNK_STEPS = 2000
"""Steps per request of a simulation run in chunks (with progress)."""

T = TypeVar("T")
Plan = Generator[tuple[Any, int], Any, T]
"""Yields (call, done after it) and receives each call's answer; returns the joined answer."""


@dataclass(frozen=True)
class Chunks(Generic[T]):
    """How one call is sent in chunks when progress is asked for: `total` units of work
    ("states" of a batch or "steps" of a simulation), sent `size` at a time by `plan()`."""

    total: int
    unit: str
    size: int
    plan: Callable[[], Plan[T]]

    @property
    def worth_it(self) -> bool:
        """More than one chunk of work."""
        return self.total > self.size


def check(progress: Any) -> Progress:
    if progress is None or progress is False:
        return None
    if progress is True:
        _tqdm()
        return True
    if not callable(progress):
        raise InputError(
            "progress must be a callable (done, total), True for a tqdm bar, or "
            f"None; not {type(progress).__name__}"
        )
    callback: ProgressCallback = progress
    return callback


def _tqdm() -> Any:
    try:
        from tqdm.auto import tqdm
    except ImportError:
        raise InputError(
            "progress=True shows a tqdm bar: pip install tqdm (or pass a callable (done, total))"
        ) from None
    return tqdm


class Reporter:
    """Reports `done` out of `total` to a callback or a tqdm bar; a context manager."""

    def __init__(self, progress: Progress, total: int, unit: str) -> None:
        self.total, self._done = total, 0
        self._bar = _tqdm()(total=total, unit=unit) if progress is True else None
        self._callback = progress if callable(progress) else None

    def __call__(self, done: int) -> None:
        if self._bar is not None:
            self._bar.update(done - self._done)
        if self._callback is not None:
            self._callback(done, self.total)
        self._done = done

    def __enter__(self) -> Reporter:
        return self

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.close()


class StreamReporter:
    """Reports the progress lines of a server's stream — {"done", "total", "unit", "stage"} —
    to a callback or a tqdm bar (made at the first line); a context manager."""

    def __init__(self, progress: Progress) -> None:
        self._progress = progress
        self._callback = progress if callable(progress) else None
        self._bar: Any = None
        self._done, self._total = 0, 0

    def __call__(self, event: Mapping[str, Any]) -> None:
        done, total = int(event["done"]), int(event["total"])
        if self._progress is True:
            if self._bar is None:
                self._bar = _tqdm()(total=total, unit=str(event.get("unit") or "it"))
            if event.get("stage"):
                self._bar.set_description(str(event["stage"]), refresh=False)
            self._bar.update(done - self._done)
        if self._callback is not None:
            self._callback(done, total)
        self._done, self._total = done, total

    def finish(self) -> None:
        """The answer is in: report done == total (when anything was reported)."""
        if self._total and self._done < self._total:
            self({"done": self._total, "total": self._total})

    def __enter__(self) -> StreamReporter:
        return self

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.close()
