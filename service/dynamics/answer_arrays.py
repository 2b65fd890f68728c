"""Where a batch's answer arrays are made: new memory, or memory the request provides.

A request whose binary answer goes into a shared-memory answer file (a co-located client's,
`service.segments`) provides the arrays there, so that the batch is computed straight into
the file and no 3 MB answer (10,000 Talos torques) is copied into it afterwards. The
provider is set for the request's context (`provided_by`) and read where the answer arrays
are made, in the thread that asks for them (`empty`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np

Shapes = Mapping[str, tuple[int, ...]]
Provider = Callable[[Shapes], dict[str, np.ndarray] | None]

_PROVIDER: ContextVar[Provider | None] = ContextVar("answer_arrays", default=None)


def empty(shapes: Shapes) -> dict[str, np.ndarray]:
    """Uninitialised float64 answer arrays of `shapes` (C order): the request's provided
    ones, else new."""
    provide = _PROVIDER.get()
    provided = None if provide is None else provide(shapes)
    if provided is not None:
        return provided
    return {name: np.empty(shape) for name, shape in shapes.items()}


@contextmanager
def provided_by(provide: Provider) -> Iterator[None]:
    """Answer arrays made in this context (and the worker threads it is copied into) come
    from `provide` (None from it: new memory)."""
    token = _PROVIDER.set(provide)
    try:
        yield
    finally:
        _PROVIDER.reset(token)
