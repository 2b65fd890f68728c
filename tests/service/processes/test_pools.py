"""A helper pool answers every call within its time: a helper that does not answer (stopped,
hung) is killed with its pool, the call raises `HelperTimedOut`, the calls waiting on that pool
`BrokenProcessPool`, and the next call is served by a new pool."""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from concurrent.futures.process import BrokenProcessPool

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
        outcomes: list[BaseException] = []

        def call() -> None:
            try:
                pool.call(abs, -5)
            except BaseException as exc:
                outcomes.append(exc)

        calls = [threading.Thread(target=call) for _ in range(2)]
        for thread in calls:
            thread.start()
        for thread in calls:
            thread.join(END_S)
        # the first to time out kills the pool: the other's wait ends then, or times out too
        assert len(outcomes) == 2, outcomes
        assert all(isinstance(exc, BrokenProcessPool | HelperTimedOut) for exc in outcomes)
        assert any(isinstance(exc, HelperTimedOut) for exc in outcomes)
        assert not wait_ended({helper}, END_S), "the stopped helper is still there"
        assert pool.call(abs, -6) == 6  # a new pool
        assert pool.executor() is not executor
    finally:
        with contextlib.suppress(ProcessLookupError, UnboundLocalError):
            os.kill(helper, signal.SIGKILL)
        pool.close()
