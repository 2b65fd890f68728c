"""Identification in its worker process: the same answer as in process, domain errors as
themselves, a bounded queue, a fit stopped at its time limit or when its caller gives up (the
worker killed and replaced), and a worker killed from outside reported as the machine's
condition (503), not the log's."""

from __future__ import annotations

import asyncio
import os
import signal
import threading

import numpy as np
import pytest

from service.api.workers.identification import IdentificationWorker
from service.dynamics.identification import identify
from service.errors import DimensionMismatch, InvalidInput, Overloaded
from service.registry.catalog import load_catalog
from tests.descendants import wait_ended
from tests.service.dynamics.identification_logs import synthetic_log

END_S = 30.0  # a killed worker process is gone well within this


@pytest.fixture(scope="module")
def ur5():
    return load_catalog(["ur5"])[0]["ur5"]


@pytest.fixture(scope="module")
def log(ur5):
    return synthetic_log(ur5.model, seed=1, duration=6.0, rate=50.0, noise=0.05)


@pytest.fixture(scope="module")
def long_log(ur5):
    """A log whose fit takes seconds (a minute at 1 kHz)."""
    return synthetic_log(ur5.model, seed=2, duration=60.0, rate=1000.0)


@pytest.fixture(scope="module")
def worker():
    worker = IdentificationWorker(timeout_s=60.0)
    yield worker
    worker.close()


def _fit(worker, ur5, log, **options):
    return asyncio.run(worker.identify(ur5, t=log.t, q=log.q, tau=log.tau, **options))


async def _running(worker, ur5, log) -> tuple[asyncio.Task, int]:
    """A fit of `log` started in the worker (its first progress report heard): the task and the
    worker process's pid."""
    started = threading.Event()
    fit = asyncio.ensure_future(
        worker.identify(ur5, lambda *event: started.set(), t=log.t, q=log.q, tau=log.tau)
    )
    while not started.is_set():
        assert not fit.done(), fit
        await asyncio.sleep(0.02)
    return fit, worker._proc.pid


def test_the_worker_answers_what_the_process_computes_and_its_errors(worker, ur5, log):
    """(One worker for both: starting one imports the identification modules, seconds.)"""
    with pytest.raises(DimensionMismatch, match="each row of q must have 6 entries"):
        asyncio.run(worker.identify(ur5, t=log.t, q=log.q[:, :5], tau=log.tau))
    inputs = {
        "t": log.t,
        "q": log.q,
        "tau": log.tau,
        "v": log.v,
        "a": log.a,
        "friction": "viscous",
        "method": "least-squares",
    }
    there = asyncio.run(worker.identify(ur5, **inputs))  # the worker still serves after an error
    here = identify(ur5, **inputs)
    np.testing.assert_allclose(there.parameters, here.parameters, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(there.rmse["validation"], here.rmse["validation"], rtol=1e-6)
    assert there.base_parameters["expressions"] == here.base_parameters["expressions"]


def test_a_cancelled_fit_kills_its_worker_and_a_new_one_serves(worker, ur5, log, long_log):
    async def cancel_a_running_fit() -> int:
        fit, pid = await _running(worker, ur5, long_log)
        fit.cancel()
        with pytest.raises(asyncio.CancelledError):
            await fit
        return pid

    pid = asyncio.run(cancel_a_running_fit())
    assert not wait_ended({pid}, END_S), "the fit went on in its worker"
    assert _fit(worker, ur5, log).physically_consistent  # a new worker
    assert worker._proc.pid != pid


def test_a_cancelled_waiting_fit_leaves_the_queue(worker, ur5, log, long_log):
    """The queue holds one fit beside the running one; a waiting fit whose caller gives up
    frees its place at once, and the running fit is not disturbed."""

    async def scenario() -> None:
        running, pid = await _running(worker, ur5, long_log)
        waiting = asyncio.ensure_future(worker.identify(ur5, t=log.t, q=log.q, tau=log.tau))
        await asyncio.sleep(0.1)
        with pytest.raises(Overloaded, match="already running and waiting"):
            await worker.identify(ur5, t=log.t, q=log.q, tau=log.tau)
        waiting.cancel()
        await asyncio.sleep(0.1)
        third = asyncio.ensure_future(worker.identify(ur5, t=log.t, q=log.q, tau=log.tau))
        assert (await running).samples["train"] > 0
        assert (await third).physically_consistent
        assert worker._proc.pid == pid  # no worker was killed

    asyncio.run(scenario())


def test_a_worker_killed_from_outside_is_overloaded_not_the_logs_fault(worker, ur5, log, long_log):
    """The kernel's OOM killer sends SIGKILL: that says nothing of the log (not a 422)."""

    async def kill_during_a_fit() -> None:
        fit, pid = await _running(worker, ur5, long_log)
        os.kill(pid, signal.SIGKILL)
        with pytest.raises(Overloaded, match=r"killed by signal 9 \(SIGKILL\).*out of memory"):
            await fit

    asyncio.run(kill_during_a_fit())
    assert _fit(worker, ur5, log).physically_consistent  # and the next fit is served


@pytest.mark.slow
def test_waiting_fits_are_bounded(ur5, log):
    worker = IdentificationWorker(timeout_s=60.0, max_waiting=0)

    async def three() -> list[str]:
        async def one() -> str:
            try:
                await worker.identify(ur5, t=log.t, q=log.q, tau=log.tau)
                return "ok"
            except Overloaded:
                return "overloaded"

        return list(await asyncio.gather(one(), one(), one()))

    try:
        outcomes = asyncio.run(three())
    finally:
        worker.close()
    assert sorted(outcomes) == ["ok", "overloaded", "overloaded"]


@pytest.mark.slow
def test_a_fit_over_the_time_limit_is_stopped_and_the_next_one_served(ur5, log, long_log):
    worker = IdentificationWorker(timeout_s=0.2)
    try:
        with pytest.raises((InvalidInput, Overloaded), match="limit"):
            _fit(worker, ur5, long_log)
        worker.timeout_s = 60.0
        assert _fit(worker, ur5, log).physically_consistent
    finally:
        worker.close()
