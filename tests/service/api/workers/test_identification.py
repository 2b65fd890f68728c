"""Identification in its worker process: the same answer as in process, domain errors as
themselves, a time limit that stops the fit, and a bound on waiting fits."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from service.api.workers.identification import IdentificationWorker
from service.dynamics.identification import identify
from service.errors import DimensionMismatch, InvalidInput, Overloaded
from service.registry.catalog import load_catalog
from tests.service.dynamics.identification_logs import synthetic_log


@pytest.fixture(scope="module")
def ur5():
    return load_catalog(["ur5"])[0]["ur5"]


@pytest.fixture(scope="module")
def log(ur5):
    return synthetic_log(ur5.model, seed=1, duration=6.0, rate=50.0, noise=0.05)


@pytest.fixture(scope="module")
def worker():
    worker = IdentificationWorker(timeout_s=60.0)
    yield worker
    worker.close()


def test_the_worker_answers_what_the_process_computes_and_its_errors(worker, ur5, log):
    """(One worker for both: starting one imports the identification modules, seconds.)"""
    with pytest.raises(DimensionMismatch, match="each row of q must have 6 entries"):
        worker.identify(ur5, t=log.t, q=log.q[:, :5], tau=log.tau)
    inputs = {
        "t": log.t,
        "q": log.q,
        "tau": log.tau,
        "v": log.v,
        "a": log.a,
        "friction": "viscous",
        "method": "least-squares",
    }
    there = worker.identify(ur5, **inputs)  # the worker still serves after an error
    here = identify(ur5, **inputs)
    np.testing.assert_allclose(there.parameters, here.parameters, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(there.rmse["validation"], here.rmse["validation"], rtol=1e-6)
    assert there.base_parameters["expressions"] == here.base_parameters["expressions"]


@pytest.mark.slow
def test_waiting_fits_are_bounded(ur5, log):
    worker = IdentificationWorker(timeout_s=60.0, max_waiting=0)
    outcomes: list[str] = []

    def call() -> None:
        try:
            worker.identify(ur5, t=log.t, q=log.q, tau=log.tau)
            outcomes.append("ok")
        except Overloaded:
            outcomes.append("overloaded")

    try:
        threads = [threading.Thread(target=call) for _ in range(3)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(120)
    finally:
        worker.close()
    assert sorted(outcomes)[0] == "ok" and "overloaded" in outcomes


@pytest.mark.slow
def test_a_fit_over_the_time_limit_is_stopped_and_the_next_one_served(ur5, log):
    worker = IdentificationWorker(timeout_s=0.2)
    try:
        long = synthetic_log(ur5.model, seed=2, duration=60.0, rate=1000.0)
        with pytest.raises((InvalidInput, Overloaded), match="limit"):
            worker.identify(ur5, t=long.t, q=long.q, tau=long.tau)
        assert worker._proc is None  # killed
        worker.timeout_s = 60.0
        assert worker.identify(ur5, t=log.t, q=log.q, tau=log.tau).physically_consistent
    finally:
        worker.close()
