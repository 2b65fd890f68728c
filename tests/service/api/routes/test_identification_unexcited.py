"""Identification of a log in which one joint barely moves (the UR5's elbow trembles over 0.008
rad): the answer names it in `warnings`, its friction entry is null, the stored variant adds no
friction on it, and that variant predicts the elbow of a fresh log (every joint moving) no worse
than the same robot without friction, while its other joints' friction improves their
predictions."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient

from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.service.dynamics.identification_logs import synthetic_log

ELBOW = 2


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    registry = Registry(tmp_path_factory.mktemp("store"), ["ur5"])
    registry.load()
    settings = Settings(data_dir=registry.store.dir.parent, catalog="ur5")
    with TestClient(
        create_app(settings, registry=registry), raise_server_exceptions=False
    ) as client:
        yield client


def _torques(model, pi, log, q, v, a, noise, seed):
    true = model.copy()
    for j, block in enumerate(pi.reshape(-1, 10), start=1):
        true.inertias[j] = pin.Inertia.FromDynamicParameters(block)
    data = true.createData()
    tau = np.array([pin.rnea(true, data, q[i], v[i], a[i]) for i in range(q.shape[0])])
    tau += log.offset + log.coulomb * np.sign(v) + log.viscous * v
    return tau + np.random.default_rng(seed).normal(0.0, noise, tau.shape)


def test_a_barely_moving_joint_is_named_and_its_friction_left_out(client):
    model = client.app.state.registry.get("ur5").model
    log = synthetic_log(model, seed=1, duration=12.0, rate=200.0, noise=0.0)
    q, v, a = log.q.copy(), log.v.copy(), log.a.copy()
    w = 2 * np.pi * 0.5  # the elbow trembles: ±0.004 rad at 0.5 Hz around 1 rad
    q[:, ELBOW] = 1.0 + 0.004 * np.sin(w * log.t)
    v[:, ELBOW] = 0.004 * w * np.cos(w * log.t)
    a[:, ELBOW] = -0.004 * w * w * np.sin(w * log.t)
    tau = _torques(model, log.pi, log, q, v, a, noise=0.05, seed=2)
    body = {"t": log.t.tolist(), "q": q.tolist(), "tau": tau.tolist()}
    answer = client.post("/v1/robots/ur5/identify", json=body)
    assert answer.status_code == 200, answer.text
    result = answer.json()
    assert [w["joint"] for w in result["warnings"]] == ["elbow_joint"]
    warning = result["warnings"][0]
    assert (
        warning["code"] == "unexcited_joint"
        and "elbow_joint moves over 0.008 rad" in warning["detail"]
    )
    assert result["friction"][ELBOW] is None
    assert all(f is not None for i, f in enumerate(result["friction"]) if i != ELBOW)
    stored = result["robot"]
    elbow_row = [f for f in stored["friction"] if f["joint"] == "elbow_joint"]
    assert all(f["coulomb"] == f["viscous"] == f["offset"] == 0.0 for f in elbow_row)

    # a fresh log of the same robot, every joint moving: the stored variant with its friction
    # predicts the elbow exactly as without it, and the other joints better
    fresh = synthetic_log(model, seed=9, duration=4.0, rate=50.0, noise=0.0, pi=log.pi)
    measured = _torques(model, log.pi, log, fresh.q, fresh.v, fresh.a, noise=0.0, seed=3)

    def rmse(friction: bool) -> np.ndarray:
        got = client.post(
            f"/v1/robots/{stored['id']}/inverse-dynamics",
            json={
                "q": fresh.q.tolist(),
                "v": fresh.v.tolist(),
                "a": fresh.a.tolist(),
                "friction": friction,
            },
        ).json()["tau"]
        return np.sqrt(np.mean((np.array(got) - measured) ** 2, axis=0))

    with_friction, without = rmse(True), rmse(False)
    assert with_friction[ELBOW] <= without[ELBOW] * (1 + 1e-12)
    others = [j for j in range(6) if j != ELBOW]
    assert (with_friction[others] < 0.5 * without[others]).all()
