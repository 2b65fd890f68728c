"""Durability of the model store: an interrupted write leaves no record, and SIGKILL of the whole
server at random moments during concurrent uploads loses no acknowledged upload and leaves no
partial or corrupt record."""

from __future__ import annotations

import json
import os
import random
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import httpx
import numpy as np
import pytest

from service.registry.store import STALE_TMP_S, ModelStore
from tests.helpers import planar_arm_closed_form, planar_arm_urdf


def _record(model_id: str) -> dict:
    # complete by the store's schema (service.registry.records): an incomplete one is skipped
    return {
        "id": model_id,
        "format": "urdf",
        "description": "<robot/>",
        "root_joint": "fixed",
        "gravity": [0, 0, -9.81],
        "name": model_id,
        "warnings": [],
        "summary": {
            "id": model_id,
            "name": model_id,
            "source": "upload",
            "nq": 0,
            "nv": 0,
            "root_joint": "fixed",
        },
    }


def test_a_write_interrupted_before_the_rename_leaves_no_record(tmp_path, monkeypatch):
    store = ModelStore(tmp_path)
    store.write(_record("u-kept"))

    def crash(*args, **kwargs):
        raise OSError("disk gone")

    monkeypatch.setattr(os, "replace", crash)
    with pytest.raises(OSError):
        store.write(_record("u-lost"))
    monkeypatch.undo()
    assert store.ids() == ["u-kept"]
    assert store.read("u-lost") is None and store.read("u-kept")["id"] == "u-kept"
    assert not list(store.dir.glob(".tmp-*"))


def test_stale_temporary_files_are_removed_and_never_read(tmp_path):
    store = ModelStore(tmp_path)
    old, fresh = store.dir / ".tmp-old.json", store.dir / ".tmp-fresh.json"
    for path in (old, fresh):
        path.write_text('{"id": "half')
    past = time.time() - STALE_TMP_S - 5
    os.utime(old, (past, past))
    reopened = ModelStore(tmp_path)
    assert not old.exists() and fresh.exists()  # a fresh one may belong to a live writer
    assert reopened.ids() == []


def _arm(i: int) -> tuple[str, tuple[float, float, float, float]]:
    params = (0.5 + 0.001 * i, 0.4, 1.0 + 0.01 * (i % 50), 0.5)
    return planar_arm_urdf(*params), params


@pytest.mark.slow
def test_sigkill_during_uploads_loses_nothing_acknowledged(server_factory, tmp_path):
    data_dir = tmp_path / "data"
    rng = random.Random(7)
    acknowledged: dict[str, tuple[float, float, float, float]] = {}
    counter = iter(range(10**6))
    lock = threading.Lock()
    for round_ in range(4):
        server = server_factory(data_dir=data_dir).start()
        stop = threading.Event()

        def upload_loop(server=server, stop=stop) -> None:
            with httpx.Client(base_url=server.base, timeout=30) as http:
                while not stop.is_set():
                    with lock:
                        i = next(counter)
                    urdf, params = _arm(i)
                    try:
                        r = http.post("/v1/robots", json={"urdf": urdf})
                    except httpx.TransportError:
                        return  # the server died under us: this upload was not acknowledged
                    if r.status_code == 201:
                        with lock:
                            acknowledged[r.json()["id"]] = params

        before = len(acknowledged)
        with ThreadPoolExecutor(4) as pool:
            futures = [pool.submit(upload_loop) for _ in range(4)]
            deadline = time.monotonic() + 60
            while len(acknowledged) == before and time.monotonic() < deadline:
                time.sleep(0.05)  # uploads are flowing (the first one starts the builder)
            time.sleep(rng.uniform(0.0, 1.5))
            server.kill()  # SIGKILL to the whole process group, mid-upload
            stop.set()
            for f in futures:
                f.result(timeout=60)
        assert len(acknowledged) > before, f"round {round_}: no upload acknowledged"

        # every record on disk is complete and matches its name (temporaries of killed writes,
        # named ".tmp-*", are not records: the store never reads them)
        records = [p for p in (data_dir / "models").glob("*.json") if not p.name.startswith(".")]
        assert set(ModelStore(data_dir).ids()) == {p.stem for p in records}
        for path in records:
            record = json.loads(path.read_text())
            assert record["id"] == path.stem and record["description"].startswith("<?xml")

    # after a final restart every acknowledged upload is served, with the right physics
    server = server_factory(data_dir=data_dir).start()
    with httpx.Client(base_url=server.base, timeout=30) as http:
        listed = {r["id"] for r in http.get("/v1/robots").json()["robots"]}
        assert set(acknowledged) <= listed
        q = np.array([0.4, -0.7])
        for robot_id, params in acknowledged.items():
            r = http.post(f"/v1/robots/{robot_id}/mass-matrix", json={"q": q.tolist()})
            assert r.status_code == 200, r.text
            expected, _, _ = planar_arm_closed_form(*params, q, np.zeros(2))
            np.testing.assert_allclose(r.json()["mass_matrix"], expected, rtol=1e-10)
    assert len(acknowledged) >= 8
