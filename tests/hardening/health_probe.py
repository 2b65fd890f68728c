"""Measure /health/live while something else runs: the event loop's responsiveness."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import TypeVar

import httpx

T = TypeVar("T")


def health_latencies_during(base: str, action: Callable[[], T]) -> tuple[T, list[float]]:
    """Run `action` while a thread probes `base`/health/live every 5 ms (from 0.2 s before to
    0.2 s after it; bounded in count): its result and the probes' latencies in seconds."""
    latencies: list[float] = []
    stop = threading.Event()

    def probe() -> None:
        with httpx.Client(timeout=5) as client:
            while not stop.is_set() and len(latencies) < 100_000:
                t = time.perf_counter()
                assert client.get(base + "/health/live").status_code == 200
                latencies.append(time.perf_counter() - t)
                time.sleep(0.005)

    prober = threading.Thread(target=probe)
    prober.start()
    try:
        time.sleep(0.2)
        result = action()
        time.sleep(0.2)
    finally:
        stop.set()
        prober.join(10)
    return result, latencies
