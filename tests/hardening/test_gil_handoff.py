"""A long computation in a worker thread leaves the GIL to a waiting thread (the event loop):
a contact-inverse-dynamics batch solves a small least-squares problem per state (NumPy's
LAPACK, which releases the GIL and takes it back at every state), and without the hand-over of
`service.dynamics.stopping` the waiting thread got the GIL only a few times in 1.7 s."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from service.api.quantities import SPECS
from service.dynamics import run
from service.states import States
from tests.hardening.test_request_costs_live import SOLO_Q, contacts_of


@pytest.mark.slow  # a latency bound
@pytest.mark.parametrize("quantity", ["contact-inverse-dynamics", "simulate"])
def test_a_long_computation_hands_the_gil_to_the_waiting_thread(
    catalog_registry, quantity: str
) -> None:
    robot = catalog_registry.get("solo12")
    rng = np.random.default_rng(0)
    if quantity == "simulate":
        s = States({"q": np.array([SOLO_Q]), "v": np.zeros((1, robot.nv))}, False)
        options = {
            "dt": 1e-4,
            "steps": 8000,
            "integrator": "rk4",
            "contacts": contacts_of("solo12"),
            "max_simulation_steps": 10**6,
            "max_simulation_work": 10**12,
        }
    else:
        n = 20_000
        s = States(
            {
                "q": np.tile(np.array(SOLO_Q), (n, 1)),
                "v": 0.1 * rng.normal(size=(n, robot.nv)),
                "a": 0.1 * rng.normal(size=(n, robot.nv)),
            },
            True,
        )
        options = {"contacts": contacts_of("solo12")}
    worker = threading.Thread(
        target=run, args=(robot, SPECS[quantity].quantity, s, options, lambda: False)
    )
    worker.start()
    waits = []
    while worker.is_alive():
        started = time.perf_counter()
        time.sleep(0.001)
        waits.append(time.perf_counter() - started)
    worker.join()
    assert len(waits) > 50, len(waits)
    assert max(waits) < 0.1, sorted(waits)[-5:]
