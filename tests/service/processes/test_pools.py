"""A helper pool answers every call within its time: a helper that does not answer (stopped,
hung) is killed with its pool, the call raises `HelperTimedOut`, the calls waiting on that pool
`BrokenProcessPool`, and the next call is served by a new pool."""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from concurrent.futures.process import BrokenProcessPool

import pytest

from service.processes import HelperPool, HelperTimedOut, ResourceLimits
from tests.descendants import wait_ended

END_S = 30.0


def test_a_stopped_helper_is_killed_and_replaced():
    pool = HelperPool(1, ResourceLimits(niceness=0), timeout_s=1.0, start_timeout_s=60.0)
    try:
        assert pool.call(abs, -3) == 3  # started (its start has its own allowance)
        executor = pool.executor()
        (helper,) = list(executor._processes)  # (the executor's own table of its processes)
        os.kill(helper, signal.SIGSTOP)
        waiting: list[BaseException] = []

        def wait_too() -> None:
            try:
                pool.call(abs, -5)
            except BaseException as exc:
                waiting.append(exc)

        other = threading.Thread(target=wait_too)
        other.start()
        with pytest.raises(HelperTimedOut):
            pool.call(abs, -4)
        other.join(END_S)
        assert len(waiting) == 1 and isinstance(waiting[0], BrokenProcessPool | HelperTimedOut)
        assert not wait_ended({helper}, END_S), "the stopped helper is still there"
        assert pool.call(abs, -6) == 6  # a new pool
        assert pool.executor() is not executor
    finally:
        with contextlib.suppress(ProcessLookupError, UnboundLocalError):
            os.kill(helper, signal.SIGKILL)
        pool.close()
