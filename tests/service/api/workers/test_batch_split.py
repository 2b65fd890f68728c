"""Large mass-matrix and Coriolis batches split between the serving process and helper
processes give bit for bit what in-process Pinocchio gives state by state; a helper killed or
stopped in the middle of a batch costs time, never a wrong answer or an error; the helpers end
with the app, leaving no process and no shared memory behind."""

from __future__ import annotations

import os
import signal
import time

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient
from starlette.requests import HTTPConnection

from service import dynamics
from service.api.workers import batch_split
from service.api.workers.batch_split import BatchSplit
from service.main import create_app
from service.settings import Settings
from service.states import States
from tests.descendants import wait_ended
from tests.helpers import random_configuration

READY_S = 120.0  # a helper imports Pinocchio and service.dynamics first
END_S = 30.0


def _ready(split: BatchSplit, robot, quantity) -> None:
    """Run a batch (which starts the helpers), then wait until every helper is ready."""
    n = batch_split.MIN_SPLIT_WORK // robot.nv + 1
    states = _states(robot.model, n, np.random.default_rng(0))
    dynamics.run(
        robot, quantity, States({k: states[k] for k in quantity.inputs}, True), {}, None, split
    )
    deadline = time.monotonic() + READY_S
    for slot in split._slots:
        while not slot.helper.ready():
            assert time.monotonic() < deadline, "a batch helper did not become ready"
            time.sleep(0.05)


def _states(model, n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    return {
        "q": np.stack([random_configuration(model, rng) for _ in range(n)]),
        "v": rng.normal(size=(n, model.nv)),
    }


def _reference(model, quantity: str, s: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """In-process Pinocchio state by state (one Data), independent of the service's code."""
    data = model.createData()
    n = s["q"].shape[0]
    if quantity == "mass-matrix":
        return {"mass_matrix": np.stack([pin.crba(model, data, s["q"][i]) for i in range(n)])}
    C = np.stack([pin.computeCoriolisMatrix(model, data, s["q"][i], s["v"][i]) for i in range(n)])
    return {"coriolis_matrix": C}


@pytest.fixture(scope="module")
def split():
    split = BatchSplit(1, 64 << 20)
    yield split
    split.close()


@pytest.fixture
def record_slices(monkeypatch):
    """The slices the helpers answered (start, stop)."""
    answered: list[tuple[int, int]] = []
    collect = BatchSplit._collect

    def recorded(self, part, out, wait_s):
        ok = collect(self, part, out, wait_s)
        if ok:
            answered.append((part.start, part.stop))
        return ok

    monkeypatch.setattr(BatchSplit, "_collect", recorded)
    return answered


@pytest.mark.parametrize("robot_id", ["talos", "ur5", "solo12", "double_pendulum_continuous"])
@pytest.mark.parametrize("quantity_name", ["mass-matrix", "coriolis"])
def test_split_batches_equal_in_process_pinocchio(
    catalog_registry, split, record_slices, monkeypatch, robot_id, quantity_name
):
    monkeypatch.setattr(batch_split, "MIN_SPLIT_WORK", 0)  # small robots split too
    robot = catalog_registry.get(robot_id)
    quantity = dynamics.QUANTITIES[quantity_name]
    _ready(split, robot, quantity)
    s = _states(robot.model, 700, np.random.default_rng(3))
    states = States({k: s[k] for k in quantity.inputs}, True)
    got = dynamics.run(robot, quantity, states, {}, None, split)
    assert record_slices and record_slices[-1][1] == 700  # a helper computed the last states
    for name, expected in _reference(robot.model, quantity_name, s).items():
        assert np.array_equal(got[name], expected), name
    serial = dynamics.run(robot, quantity, states, {})
    for name, value in serial.items():
        assert np.array_equal(got[name], value), name
    if quantity_name == "coriolis":  # C v of the split batch: the matrices' own products
        Cv = np.einsum("nij,nj->ni", got["coriolis_matrix"], s["v"])
        np.testing.assert_allclose(got["coriolis_forces"], Cv, rtol=1e-12, atol=1e-12)


def test_small_batches_stay_in_process(catalog_registry, split, record_slices):
    robot = catalog_registry.get("talos")
    quantity = dynamics.QUANTITIES["mass-matrix"]
    _ready(split, robot, quantity)
    record_slices.clear()
    n = batch_split.MIN_SPLIT_WORK // robot.nv - 1
    s = _states(robot.model, n, np.random.default_rng(4))
    got = dynamics.run(robot, quantity, States({"q": s["q"]}, True), {}, None, split)
    assert record_slices == []
    assert np.array_equal(
        got["mass_matrix"], _reference(robot.model, "mass-matrix", s)["mass_matrix"]
    )


@pytest.mark.parametrize("how", ["killed", "stopped"])
def test_a_helper_lost_mid_batch_gives_the_right_answer(
    catalog_registry, split, record_slices, monkeypatch, how
):
    robot = catalog_registry.get("talos")
    quantity = dynamics.QUANTITIES["coriolis"]
    _ready(split, robot, quantity)
    record_slices.clear()
    monkeypatch.setattr(batch_split, "WAIT_MIN_S", 0.5)  # a stopped helper is given up soon
    (slot,) = split._slots
    first = slot.helper.proc
    assert first is not None and first.pid is not None
    hand_out = BatchSplit._hand_out

    def then_lose_the_helper(self, *args):
        parts = hand_out(self, *args)  # the helper has its slice and computes it
        os.kill(first.pid, signal.SIGKILL if how == "killed" else signal.SIGSTOP)
        return parts

    monkeypatch.setattr(BatchSplit, "_hand_out", then_lose_the_helper)
    s = _states(robot.model, 1500, np.random.default_rng(5))
    got = dynamics.run(robot, quantity, States(s, True), {}, None, split)
    assert record_slices == []  # the helper's slice was computed in this process
    assert np.array_equal(
        got["coriolis_matrix"], _reference(robot.model, "coriolis", s)["coriolis_matrix"]
    )
    assert not wait_ended([first.pid], END_S)  # stopped: killed and reaped
    monkeypatch.setattr(BatchSplit, "_hand_out", hand_out)
    _ready(split, robot, quantity)  # a new helper serves the next batches
    assert slot.helper.proc is not first
    record_slices.clear()
    got = dynamics.run(robot, quantity, States(s, True), {}, None, split)
    assert record_slices and np.array_equal(
        got["coriolis_matrix"], _reference(robot.model, "coriolis", s)["coriolis_matrix"]
    )


def _memfds(pid: int) -> list[str]:
    with open(f"/proc/{pid}/maps") as fh:
        mapped = [line for line in fh if "/memfd:robodyn-batch" in line]
    links = []
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            links.append(os.readlink(f"/proc/{pid}/fd/{fd}"))
        except OSError:
            continue
    return mapped + [link for link in links if link.startswith("/memfd:robodyn-batch")]


def test_over_http_then_nothing_left_after_shutdown(catalog_registry, record_slices):
    robot = catalog_registry.get("talos")
    app = create_app(
        Settings(data_dir=catalog_registry.store.dir.parent, batch_helpers=1),
        registry=catalog_registry,
    )
    s = _states(robot.model, 700, np.random.default_rng(6))
    body = {"q": s["q"].tolist()}
    before = _memfds(os.getpid())  # (other tests' splits may hold theirs)
    with TestClient(app, raise_server_exceptions=False) as client:
        split = app.state.batch_split
        assert client.post("/v1/robots/talos/mass-matrix", json=body).status_code == 200
        deadline = time.monotonic() + READY_S
        while not split._slots[0].helper.ready():
            assert time.monotonic() < deadline
            time.sleep(0.05)
        helper = split._slots[0].helper.proc
        record_slices.clear()
        answer = client.post("/v1/robots/talos/mass-matrix", json=body)
        assert answer.status_code == 200, answer.text
        assert record_slices  # the helper computed its slice
        expected = _reference(robot.model, "mass-matrix", s)["mass_matrix"]
        assert np.array_equal(np.array(answer.json()["mass_matrix"]), expected)
        os.kill(helper.pid, signal.SIGKILL)  # killed between requests: computed here, then
        answer = client.post("/v1/robots/talos/mass-matrix", json=body)  # a new one starts
        assert answer.status_code == 200, answer.text
        assert np.array_equal(np.array(answer.json()["mass_matrix"]), expected)
        assert len(_memfds(os.getpid())) > len(before)  # the helper's shared file, mapped here
        replacement = split._slots[0].helper.proc
    assert not wait_ended([helper.pid] + ([replacement.pid] if replacement else []), END_S)
    assert _memfds(os.getpid()) == before


def test_helpers_by_default_for_the_unix_socket_only(catalog_registry, tmp_path):
    """Unset, ROBODYN_BATCH_HELPERS is -1 for the requests over the Unix socket and off over
    TCP; set, it applies to every request (0: off)."""
    from service.api.routes.dynamics import _batch_split

    data_dir = catalog_registry.store.dir.parent
    cpus = len(os.sched_getaffinity(0))
    over_tcp = {"type": "http", "server": ("127.0.0.1", 8000)}
    over_socket = {"type": "http", "server": (str(tmp_path / "r.sock"), None)}

    def split_for(app, scope):
        return _batch_split(HTTPConnection({**scope, "app": app}))

    assert (
        create_app(Settings(data_dir=data_dir), registry=catalog_registry).state.batch_split
        is None  # no Unix socket: no helpers
    )
    socket_app = create_app(
        Settings(data_dir=data_dir, unix_socket=tmp_path / "r.sock"), registry=catalog_registry
    )
    split = socket_app.state.batch_split
    if cpus > 1:
        assert split.processes == cpus
        assert split_for(socket_app, over_socket) is split
        assert split_for(socket_app, over_tcp) is None
        split.close()
    else:
        assert split is None
    assert (
        create_app(
            Settings(data_dir=data_dir, unix_socket=tmp_path / "r.sock", batch_helpers=0),
            registry=catalog_registry,
        ).state.batch_split
        is None
    )
    # -1: one helper per CPU of the process but its own (its share with several workers),
    # for every request
    app = create_app(Settings(data_dir=data_dir, batch_helpers=-1), registry=catalog_registry)
    split = app.state.batch_split
    if cpus > 1:
        assert split.processes == cpus
        assert split_for(app, over_tcp) is split
        split.close()
    else:
        assert split is None
    shared = create_app(
        Settings(data_dir=data_dir, batch_helpers=-1, workers=cpus), registry=catalog_registry
    )
    assert shared.state.batch_split is None  # every CPU has a serving process already
