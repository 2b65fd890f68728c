"""A batch answers exactly what the states answer one by one, with a leading batch axis."""

from __future__ import annotations

import threading

import numpy as np
import pinocchio as pin
import pytest

from tests.helpers import random_state, record_off_loop

INPUTS = {
    "mass-matrix": "q",
    "gravity": "q",
    "coriolis": "qv",
    "nonlinear-effects": "qv",
    "inverse-dynamics": "qva",
    "forward-dynamics": "qvt",
}


def _body(inputs, q, v, a):
    names = {"q": ("q", q), "v": ("v", v), "a": ("a", a), "t": ("tau", a)}
    return {names[c][0]: np.asarray(names[c][1]).tolist() for c in inputs}


@pytest.mark.parametrize("robot", ["ur5", "talos", "double_pendulum_continuous", "solo12"])
@pytest.mark.parametrize("quantity", list(INPUTS))
def test_batch_equals_single_states(api, catalog_registry, robot, quantity):
    model = catalog_registry.catalog[robot].model
    rng = np.random.default_rng(7)
    states = [random_state(model, rng) for _ in range(4)]
    qs, vs, as_ = (np.stack(x) for x in zip(*states, strict=True))
    r = api.post(f"/v1/robots/{robot}/{quantity}", json=_body(INPUTS[quantity], qs, vs, as_))
    assert r.status_code == 200, r.text
    batch = r.json()
    for i in range(4):
        single = api.post(
            f"/v1/robots/{robot}/{quantity}", json=_body(INPUTS[quantity], qs[i], vs[i], as_[i])
        ).json()
        assert set(single) == set(batch)
        for key in single:
            # bit-identical: the same computation, one state at a time
            np.testing.assert_array_equal(np.asarray(batch[key])[i], np.asarray(single[key]))


def test_batch_shapes(api):
    q = np.zeros((3, 6)).tolist()
    r = api.post("/v1/robots/ur5/coriolis", json={"q": q, "v": q}).json()
    assert np.asarray(r["coriolis_matrix"]).shape == (3, 6, 6)
    assert np.asarray(r["coriolis_forces"]).shape == (3, 6)
    single = api.post("/v1/robots/ur5/mass-matrix", json={"q": [0.0] * 6}).json()
    assert np.asarray(single["mass_matrix"]).shape == (6, 6)
    one = api.post("/v1/robots/ur5/mass-matrix", json={"q": [[0.0] * 6]}).json()
    assert np.asarray(one["mass_matrix"]).shape == (1, 6, 6)


def test_large_batch_runs_off_the_event_loop_and_matches(api, catalog_registry):
    """A batch big enough to be computed in a worker thread gives the same numbers."""
    model = catalog_registry.catalog["talos"].model
    rng = np.random.default_rng(3)
    states = [random_state(model, rng) for _ in range(200)]
    qs, vs, as_ = (np.stack(x) for x in zip(*states, strict=True))
    r = api.post(
        "/v1/robots/talos/inverse-dynamics",
        json={"q": qs.tolist(), "v": vs.tolist(), "a": as_.tolist()},
    )
    tau = np.asarray(r.json()["tau"])
    import pinocchio as pin

    data = model.createData()
    expected = np.stack([pin.rnea(model, data, *s) for s in states])
    np.testing.assert_array_equal(tau, expected)


def test_a_parallel_batch_is_checked_and_computed_in_the_openmp_master_thread(
    api, catalog_registry, monkeypatch
):
    """A large batch with a parallel form is validated in the thread that computes it (the
    OpenMP master: no hop between the two); a batch without one (mass matrices) in a worker
    thread of the pool."""
    from service.api import inputs

    threads: list[str] = []
    original = inputs.prepare_states

    def recording(*args, **kwargs):
        threads.append(threading.current_thread().name)
        return original(*args, **kwargs)

    monkeypatch.setattr(inputs, "prepare_states", recording)
    model = catalog_registry.catalog["talos"].model
    rng = np.random.default_rng(4)
    states = [random_state(model, rng) for _ in range(200)]
    qs, vs, as_ = (np.stack(x).tolist() for x in zip(*states, strict=True))
    tau = api.post("/v1/robots/talos/inverse-dynamics", json={"q": qs, "v": vs, "a": as_})
    M = api.post("/v1/robots/talos/mass-matrix", json={"q": qs})
    assert tau.status_code == M.status_code == 200
    assert threads[0].startswith("openmp-master") and not threads[1].startswith("openmp")
    data = model.createData()
    expected = np.stack([pin.rnea(model, data, *s) for s in states])
    np.testing.assert_array_equal(np.asarray(tau.json()["tau"]), expected)


def test_large_json_batches_are_read_computed_and_encoded_off_the_event_loop(api, monkeypatch):
    """A 10,000-state JSON body takes a quarter of a second to parse: parsing, validation,
    computation and encoding of large batches run in worker threads (bounded by
    max_pending_batches), small ones inline; the answers are the same."""
    from service.api.encoding import answers
    from service.api.routes import dynamics as routes

    calls = record_off_loop(monkeypatch, routes)
    rng = np.random.default_rng(4)
    q = rng.uniform(-1, 1, (800, 6))
    big = api.post("/v1/robots/ur5/mass-matrix", json={"q": q.tolist()})
    assert big.status_code == 200 and len(big.request.content) > routes.INLINE_BODY_BYTES
    assert calls == ["parse_json", "_prepare_and_run", answers.json_pieces.__name__]
    calls.clear()
    small = api.post("/v1/robots/ur5/mass-matrix", json={"q": q[:3].tolist()})
    assert calls == [] and small.status_code == 200
    np.testing.assert_array_equal(
        np.array(small.json()["mass_matrix"]), np.array(big.json()["mass_matrix"])[:3]
    )


def test_a_large_answer_of_little_work_is_computed_and_encoded_off_the_event_loop(
    api, catalog_registry, monkeypatch
):
    """Talos' regressor: 4 states are little work (4 × nv) but an answer of 4 × nv × 10 × bodies
    numbers (about 2 MB of JSON): it is computed and encoded in worker threads, and it is
    the same answer as state by state."""
    from service.api.encoding import answers
    from service.api.routes import dynamics as routes

    talos = catalog_registry.catalog["talos"]
    per_state = talos.nv * 10 * (talos.model.njoints - 1)
    states = 4
    assert states * talos.nv < routes.INLINE_WORK < routes.INLINE_ANSWER_NUMBERS
    assert states * per_state > routes.INLINE_ANSWER_NUMBERS
    calls = record_off_loop(monkeypatch, routes)
    rng = np.random.default_rng(5)
    q = np.repeat(talos.default_configuration[None], states, 0)
    v, a = rng.uniform(-1, 1, (2, states, talos.nv))
    r = api.post(
        "/v1/robots/talos/regressor", json={"q": q.tolist(), "v": v.tolist(), "a": a.tolist()}
    )
    assert r.status_code == 200
    assert calls[-1] == answers.json_pieces.__name__ and "run" in calls
    one = api.post(
        "/v1/robots/talos/regressor",
        json={"q": q[0].tolist(), "v": v[0].tolist(), "a": a[0].tolist()},
    )
    np.testing.assert_array_equal(
        np.array(r.json()["regressor"])[0], np.array(one.json()["regressor"])
    )


@pytest.mark.parametrize(
    "quantity", ["gravity", "nonlinear-effects", "inverse-dynamics", "forward-dynamics"]
)
@pytest.mark.parametrize("robot", ["talos", "solo12", "double_pendulum_continuous"])
def test_parallel_batches_give_the_bits_of_single_states(api, catalog_registry, robot, quantity):
    """Batches of 64 states or more run on every core (rneaInParallel / abaInParallel); each
    state of such a batch is bit for bit its single-state answer."""
    from service.dynamics import QUANTITIES

    assert QUANTITIES[quantity].parallel is not None
    model = catalog_registry.catalog[robot].model
    rng = np.random.default_rng(11)
    states = [random_state(model, rng) for _ in range(QUANTITIES[quantity].parallel_from + 6)]
    qs, vs, as_ = (np.stack(x) for x in zip(*states, strict=True))
    batch = api.post(
        f"/v1/robots/{robot}/{quantity}", json=_body(INPUTS[quantity], qs, vs, as_)
    ).json()
    (key,) = batch
    for i in (0, 17, len(states) - 1):
        single = api.post(
            f"/v1/robots/{robot}/{quantity}", json=_body(INPUTS[quantity], qs[i], vs[i], as_[i])
        ).json()
        np.testing.assert_array_equal(np.asarray(batch[key])[i], np.asarray(single[key]))


def test_generalized_gravity_is_rnea_at_rest_bit_for_bit_on_every_catalog_robot(catalog_registry):
    """Why gravity batches may use rneaInParallel(q, 0, 0): Pinocchio's
    computeGeneralizedGravity gives exactly the same bits as rnea(q, 0, 0)."""
    import pinocchio as pin

    rng = np.random.default_rng(5)
    for name, robot in catalog_registry.catalog.items():
        model = robot.model
        data, zero = model.createData(), np.zeros(model.nv)
        for _ in range(3):
            q, _, _ = random_state(model, rng)
            np.testing.assert_array_equal(
                pin.computeGeneralizedGravity(model, data, q).copy(),
                pin.rnea(model, data, q, zero, zero).copy(),
                err_msg=name,
            )


def test_large_name_keyed_batches_are_converted_off_the_event_loop(
    api, catalog_registry, monkeypatch
):
    from service.api.routes import dynamics as routes

    calls = record_off_loop(monkeypatch, routes)
    names = [j["name"] for j in api.get("/v1/robots/ur5").json()["joints"] if j["nv"]]
    q = np.random.default_rng(2).uniform(-1, 1, (400, 6))
    named = [dict(zip(reversed(names), reversed(row.tolist()), strict=True)) for row in q]
    r = api.post("/v1/robots/ur5/gravity", json={"q": named})
    assert r.status_code == 200 and "_prepare_and_run" in calls
    want = api.post("/v1/robots/ur5/gravity", json={"q": q.tolist()}).json()["gravity"]
    np.testing.assert_array_equal(np.array(r.json()["gravity"]), np.array(want))


@pytest.mark.parametrize("robot", ["talos", "solo12", "ur5"])
def test_batched_mass_matrices_are_exactly_symmetric_and_equal_single_states(
    api, catalog_registry, robot
):
    """Every mass matrix of a batch is symmetric to the bit (Pinocchio's Python `crba` copies
    its upper triangle down; the service relies on that) and equals its single-state answer."""
    model = catalog_registry.catalog[robot].model
    rng = np.random.default_rng(7)
    q = np.stack(
        [pin.integrate(model, pin.neutral(model), rng.normal(0, 0.5, model.nv)) for _ in range(40)]
    )
    M = np.asarray(
        api.post(f"/v1/robots/{robot}/mass-matrix", json={"q": q.tolist()}).json()["mass_matrix"]
    )
    np.testing.assert_array_equal(M, np.swapaxes(M, 1, 2))
    single = api.post(f"/v1/robots/{robot}/mass-matrix", json={"q": q[17].tolist()}).json()
    np.testing.assert_array_equal(np.asarray(single["mass_matrix"]), M[17])
