"""`python -m service --workers 2`: concurrent requests on catalog robots and uploads answered as
in-process Pinocchio computes them, and a worker killed by a signal is replaced with every model
still served."""

from __future__ import annotations

import os
import signal
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx
import numpy as np
import pinocchio as pin
import pytest

from service.registry.build import build_urdf_model
from service.registry.catalog import load_catalog
from tests.helpers import mass_matrix, planar_arm_urdf, random_state

pytestmark = pytest.mark.slow

CATALOG = ["ur5", "panda", "talos", "solo12", "planar_arm"]
UPLOADS = [planar_arm_urdf(0.8, 0.6, 1.1, 0.9), planar_arm_urdf(1.3, 0.2, 2.0, 0.1)]


def workers_of(pid: int) -> set[int]:
    """Worker processes of a uvicorn supervisor: its children started by multiprocessing spawn."""
    out = set()
    for child in Path(f"/proc/{pid}/task/{pid}/children").read_text().split():
        cmdline = Path(f"/proc/{child}/cmdline").read_bytes()
        if b"spawn_main" in cmdline:
            out.add(int(child))
    return out


def wait_stably_ready(base: str, timeout_s: float = 60) -> None:
    """Ready answers on 30 fresh connections in a row (the kernel spreads them on workers)."""
    deadline = time.monotonic() + timeout_s
    streak = 0
    while streak < 30:
        assert time.monotonic() < deadline, "workers not ready"
        try:
            ok = httpx.get(f"{base}/health/ready", timeout=2).status_code == 200
        except httpx.TransportError:
            ok = False
        streak = streak + 1 if ok else 0
        if not ok:
            time.sleep(0.1)


@pytest.fixture(scope="module")
def models():
    robots, failures = load_catalog(CATALOG)
    assert not failures
    out = {name: robot.model for name, robot in robots.items()}
    return out


def expected(model, quantity: str, q, v, a):
    data = model.createData()
    if quantity == "mass-matrix":
        return "mass_matrix", mass_matrix(model, q)
    if quantity == "nonlinear-effects":
        return "nonlinear_effects", pin.nonLinearEffects(model, data, q, v)
    if quantity == "inverse-dynamics":
        return "tau", pin.rnea(model, data, q, v, a)
    return "a", pin.aba(model, data, q, v, a)


BODY = {
    "mass-matrix": ("q",),
    "nonlinear-effects": ("q", "v"),
    "inverse-dynamics": ("q", "v", "a"),
    "forward-dynamics": ("q", "v", "tau"),
}


def run_mixed_load(base: str, models: dict, rng: np.random.Generator, count: int) -> None:
    jobs = []
    for i in range(count):
        name = list(models)[i % len(models)]
        quantity = list(BODY)[(i // len(models)) % len(BODY)]
        q, v, a = random_state(models[name], rng)
        jobs.append((name, quantity, q, v, a))

    def call(job):
        name, quantity, q, v, a = job
        values = {"q": q, "v": v, "a": a, "tau": a}
        body = {k: values[k].tolist() for k in BODY[quantity]}
        with httpx.Client(timeout=60) as http:  # a fresh connection: any worker may answer
            return job, http.post(f"{base}/v1/robots/{name}/{quantity}", json=body)

    with ThreadPoolExecutor(12) as pool:
        results = list(pool.map(call, jobs, timeout=300))
    for (name, quantity, q, v, a), r in results:
        assert r.status_code == 200, (name, quantity, r.text)
        key, value = expected(models[name], quantity, q, v, a)
        np.testing.assert_allclose(
            r.json()[key], value, rtol=1e-10, atol=1e-10 * max(1.0, float(np.abs(value).max()))
        )


def upload_all(base: str, models: dict) -> None:
    for urdf in UPLOADS:
        r = httpx.post(f"{base}/v1/robots", json={"urdf": urdf}, timeout=60)
        assert r.status_code in (200, 201), r.text
        models[r.json()["id"]] = build_urdf_model(urdf, "fixed")


def test_two_workers_answer_like_pinocchio(server_factory, models):
    server = server_factory(workers=2, catalog=",".join(CATALOG)).start()
    wait_stably_ready(server.base)
    assert len(workers_of(server.proc.pid)) == 2
    all_models = dict(models)
    upload_all(server.base, all_models)  # stored by one worker, served by both
    run_mixed_load(server.base, all_models, np.random.default_rng(5), 300)


def test_a_killed_worker_is_replaced_and_every_model_served(server_factory, models):
    server = server_factory(workers=2, catalog=",".join(CATALOG)).start()
    wait_stably_ready(server.base)
    all_models = dict(models)
    upload_all(server.base, all_models)
    rng = np.random.default_rng(9)
    for sig in (signal.SIGKILL, signal.SIGSEGV):
        before = workers_of(server.proc.pid)
        assert len(before) == 2
        victim = min(before)
        os.kill(victim, sig)
        deadline = time.monotonic() + 60
        while True:
            now = workers_of(server.proc.pid)
            if victim not in now and len(now) == 2:
                break
            assert time.monotonic() < deadline, f"worker not replaced after {sig!r}: {now}"
            time.sleep(0.2)
        assert server.alive()
        wait_stably_ready(server.base)
        listed = {r["id"] for r in httpx.get(f"{server.base}/v1/robots").json()["robots"]}
        assert set(all_models) <= listed
        run_mixed_load(server.base, all_models, rng, 120)
