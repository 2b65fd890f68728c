"""GET /v1/robots/{id}/equations: answers equal to the in-process derivation, the cache (memory
and disk), every refusal a 422 unsupported_model, and the event loop free meanwhile."""

from __future__ import annotations

import re
import statistics
import threading
import time
from pathlib import Path

import orjson
import pytest
from fastapi.testclient import TestClient

from service.api.schemas.equations import Equations
from service.api.workers import equations_cache as cache_module
from service.dynamics.equations import derive_equations, equations_answer
from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.helpers import (
    alternating_arm_urdf,
    evaluate_printed,
    random_configuration,
    skewed_arm_urdf,
    unless_starved,
)

CATALOG = "ur5,planar_arm,talos_arm,double_pendulum_continuous,solo12"


def _client(data_dir: Path, **settings_kw) -> TestClient:
    settings = Settings(data_dir=data_dir, catalog=CATALOG, **settings_kw)
    registry = Registry(settings.data_dir, settings.catalog_names())
    registry.load()
    return TestClient(create_app(settings, registry=registry), raise_server_exceptions=False)


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory):
    with _client(tmp_path_factory.mktemp("equations")) as c:
        yield c


def _in_process(
    client: TestClient, robot_id: str, form: str = "numeric", digits: int = 6, tolerance=1e-9
) -> dict:
    model = client.app.state.registry.get(robot_id).model  # type: ignore[attr-defined]
    answer = equations_answer(derive_equations(model, form=form), digits, tolerance)
    return orjson.loads(orjson.dumps(answer))


@pytest.mark.parametrize("robot_id", ["planar_arm", "ur5"])
def test_answer_equals_the_in_process_derivation(client, robot_id):
    r = client.get(f"/v1/robots/{robot_id}/equations")
    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == "application/json"
    body = r.json()
    assert body == _in_process(client, robot_id)
    Equations.model_validate(body)  # the documented schema
    assert body["accuracy"]["digits"] == 6 and body["accuracy"]["tolerance"] == 1e-9
    if robot_id == "planar_arm":
        assert body["mass_matrix"]["expressions"][0][0] == "4.235 + 2.1*cos(q2)"


@pytest.mark.parametrize(
    ("query", "form", "digits", "tolerance"),
    [
        ("?form=parametric", "parametric", 6, 1e-9),
        ("?digits=17&tolerance=0", "numeric", 17, 0.0),
        ("?digits=3&tolerance=1e-3&form=parametric", "parametric", 3, 1e-3),
    ],
)
def test_each_printing_is_its_own_answer(client, query, form, digits, tolerance):
    r = client.get(f"/v1/robots/planar_arm/equations{query}")
    assert r.status_code == 200, r.text
    body = r.json()
    assert body == _in_process(client, "planar_arm", form, digits, tolerance)
    Equations.model_validate(body)
    assert ("parameters" in body) == (form == "parametric")
    assert body["accuracy"]["digits"] == digits


@pytest.mark.parametrize(
    ("query", "says"),
    [
        ("?digits=0", "query.digits"),
        ("?digits=18", "query.digits"),
        ("?tolerance=-1", "query.tolerance"),
        ("?tolerance=nan", "query.tolerance"),
        ("?form=symbolic", "query.form"),
    ],
)
def test_bad_printing_options_are_problems_naming_them(client, query, says):
    r = client.get(f"/v1/robots/planar_arm/equations{query}")
    assert r.status_code == 422, r.text
    assert r.headers["content-type"] == "application/problem+json"
    assert r.json()["code"] == "validation_error" and says in r.json()["detail"]


def test_a_cached_answer_is_served_without_deriving_again(client, monkeypatch):
    """The second request is answered from the cache (its time, under 50 ms, is measured by
    bench/equations.py, not asserted here)."""
    first = client.get("/v1/robots/ur5/equations")
    assert first.status_code == 200

    def no_derivation(*args):
        raise AssertionError("derived again")

    monkeypatch.setattr(cache_module, "derive_isolated", no_derivation)
    for _ in range(3):
        r = client.get("/v1/robots/ur5/equations")
        assert r.status_code == 200 and r.content == first.content


@pytest.mark.parametrize(
    ("robot_id", "status", "code", "says"),
    [
        ("talos_arm", 422, "unsupported_model", "7 moving joints"),
        ("double_pendulum_continuous", 422, "unsupported_model", "is continuous"),
        ("solo12", 422, "unsupported_model", "free-flyer root joint"),
        ("no_such_robot", 404, "robot_not_found", "no robot has id"),
    ],
)
def test_refusals_are_problems_with_the_contract_codes(client, robot_id, status, code, says):
    for _ in range(2):  # the second time from the remembered refusal
        r = client.get(f"/v1/robots/{robot_id}/equations")
        assert r.status_code == status, r.text
        assert r.headers["content-type"] == "application/problem+json"
        assert r.json()["code"] == code and says in r.json()["detail"]


def test_an_upload_is_derived_once_and_kept_on_disk(tmp_path, monkeypatch):
    with _client(tmp_path) as c:
        r = c.post("/v1/robots", json={"urdf": skewed_arm_urdf(3), "name": "skewed"})
        assert r.status_code in (200, 201), r.text
        robot_id = r.json()["id"]
        answer = c.get(f"/v1/robots/{robot_id}/equations")
        assert answer.status_code == 200, answer.text
        assert answer.json() == _in_process(c, robot_id)
    stored = tmp_path / "equations" / "v3" / robot_id / "numeric-6-1e-09.json"
    assert stored.read_bytes() == answer.content

    def no_derivation(*args):
        raise AssertionError("derived again")

    monkeypatch.setattr(cache_module, "derive_isolated", no_derivation)
    with _client(tmp_path) as restarted:  # a restart, or a replica sharing the data directory
        again = restarted.get(f"/v1/robots/{robot_id}/equations")
        assert again.status_code == 200 and again.content == answer.content


def test_a_derivation_past_its_time_limit_is_unsupported_model(tmp_path):
    with _client(tmp_path, equations_timeout_s=0.3) as c:
        robot_id = c.post("/v1/robots", json={"urdf": skewed_arm_urdf(6)}).json()["id"]
        r = unless_starved(lambda: c.get(f"/v1/robots/{robot_id}/equations"))
        assert r.status_code == 422, r.text
        assert r.json()["code"] == "unsupported_model"
        assert "time limit of 0.3 s" in r.json()["detail"]


@pytest.mark.slow  # a latency bound measured against the machine: in the slow suite
def test_health_stays_fast_while_a_derivation_runs(tmp_path):
    """The derivation runs in a child process and its request waits in a worker thread: the
    event loop answers /health/live meanwhile (probed every 5 ms)."""
    with _client(tmp_path) as c:
        robot_id = c.post("/v1/robots", json={"urdf": skewed_arm_urdf(4)}).json()["id"]
        c.get("/v1/robots/planar_arm/equations")  # the child process machinery is warm
        done = threading.Event()
        latencies: list[float] = []
        result: dict = {}

        def derive() -> None:
            started = time.perf_counter()
            result["response"] = c.get(f"/v1/robots/{robot_id}/equations")
            result["seconds"] = time.perf_counter() - started
            done.set()

        worker = threading.Thread(target=derive)
        worker.start()
        while not done.is_set():
            started = time.perf_counter()
            assert c.get("/health/live").status_code == 200
            latencies.append(time.perf_counter() - started)
            time.sleep(0.005)
        worker.join()
    assert result["response"].status_code == 200
    assert result["seconds"] > 0.2 and len(latencies) >= 10, (result, len(latencies))
    assert max(latencies) < 0.1 and statistics.median(latencies) < 0.02, latencies


@pytest.mark.slow  # a real server: with the other latency probes of the slow suite
def test_a_real_server_answers_health_while_it_derives(tmp_path):
    """`python -m service`: /health/live probed every 5 ms while a skewed 6-joint arm (seconds
    of derivation and printing in a child process) is derived."""
    import httpx

    from tests.hardening.health_probe import health_latencies_during
    from tests.servers import running_server

    with (
        running_server(tmp_path, catalog="planar_arm") as url,
        httpx.Client(base_url=url, timeout=120) as http,
    ):
        robot_id = http.post("/v1/robots", json={"urdf": skewed_arm_urdf(6)}).json()["id"]
        answer, latencies = health_latencies_during(
            url, lambda: http.get(f"/v1/robots/{robot_id}/equations")
        )
    assert answer.status_code == 200, answer.text
    assert len(latencies) >= 20, latencies
    assert max(latencies) < 0.5 and statistics.median(latencies) < 0.05, latencies


def _mass_matrix_error(answer: dict, model) -> float:
    """The largest |printed M − Pinocchio's M| at three random states, the parametric form's
    parameters substituted."""
    import numpy as np
    import pinocchio as pin

    values = {p["symbol"]: p["value"] for p in answer.get("parameters", [])}
    data = model.createData()
    rng = np.random.default_rng(0)
    worst = 0.0
    for _ in range(3):
        q = random_configuration(model, rng)
        at = {**values, **{f"q{i + 1}": float(x) for i, x in enumerate(q)}}
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        printed = [
            [evaluate_printed(e, at) for e in row] for row in answer["mass_matrix"]["expressions"]
        ]
        worst = max(worst, float(np.abs(np.array(printed) - M).max()))
    return worst


@pytest.mark.parametrize(
    ("urdf", "forms"),
    [(alternating_arm_urdf(), ("numeric", "parametric")), (skewed_arm_urdf(6), ("numeric",))],
    ids=["alternating", "skewed"],
)
def test_six_joint_arms_answer_in_both_forms(tmp_path, urdf, forms):
    """The alternating-axis 6R arm and a skewed 6R arm (no two axes parallel) answer 200,
    their M within the accuracy bound of Pinocchio's (their time: the slow suite)."""
    with _client(tmp_path) as c:
        robot_id = c.post("/v1/robots", json={"urdf": urdf}).json()["id"]
        model = c.app.state.registry.get(robot_id).model  # type: ignore[attr-defined]
        for form in forms:
            r = unless_starved(lambda f=form: c.get(f"/v1/robots/{robot_id}/equations?form={f}"))
            assert r.status_code == 200, r.text
            answer = r.json()
            bound = answer["accuracy"]["max_abs_error"]["mass_matrix"]
            assert _mass_matrix_error(answer, model) <= bound + 1e-9, form


@pytest.mark.slow  # the time of a first request, measured on the machine
def test_six_joint_arms_answer_within_10_s_cold_while_health_answers(tmp_path):
    """`python -m service`, fresh: the first request of each form for the alternating-axis 6R
    arm and a random skewed 6R arm answers 200 within 10 s (the first one also starts the
    forkserver), /health/live probed meanwhile."""
    import httpx

    from tests.hardening.health_probe import health_latencies_during
    from tests.servers import running_server

    with (
        running_server(tmp_path, catalog="planar_arm") as url,
        httpx.Client(base_url=url, timeout=120) as http,
    ):
        for urdf in (alternating_arm_urdf(), skewed_arm_urdf(6, seed=7)):
            robot_id = http.post("/v1/robots", json={"urdf": urdf}).json()["id"]
            for form in ("numeric", "parametric"):

                def timed(f: str = form, rid: str = robot_id) -> tuple[httpx.Response, float]:
                    started = time.perf_counter()
                    response = http.get(f"/v1/robots/{rid}/equations?form={f}")
                    return response, time.perf_counter() - started

                (answer, seconds), latencies = health_latencies_during(url, timed)
                assert answer.status_code == 200, answer.text
                assert seconds < 10.0, (form, seconds)
                assert latencies and max(latencies) < 0.5, latencies


def _renamed(urdf: str) -> str:
    """The same arm under other names (robot, links, joints): the same numbers, another id."""
    return re.sub(r'\b(name|link)="', r'\1="other_', urdf)


def test_a_refusal_for_cost_is_remembered_for_every_robot_with_the_same_numbers(
    tmp_path, monkeypatch
):
    with _client(tmp_path, equations_timeout_s=0.3) as c:
        first = c.post("/v1/robots", json={"urdf": skewed_arm_urdf(6)}).json()["id"]
        renamed = c.post("/v1/robots", json={"urdf": _renamed(skewed_arm_urdf(6))}).json()["id"]
        assert renamed != first
        for _ in range(5):  # a derivation the busy machine starved is a 503: tried again
            refused = c.get(f"/v1/robots/{first}/equations")
            if refused.status_code != 503:
                break
        assert refused.status_code == 422, refused.text
        assert "time limit of 0.3 s" in refused.json()["detail"]

        def no_derivation(*args):
            raise AssertionError("derived again")

        monkeypatch.setattr(cache_module, "derive_isolated", no_derivation)
        for robot_id in (first, renamed):  # at once, never a 503, whatever the printing
            for query in ("", "?digits=17&tolerance=0"):
                again = c.get(f"/v1/robots/{robot_id}/equations{query}")
                assert again.status_code == 422 and again.json() == refused.json()


def test_derivations_have_slots_of_their_own(tmp_path, monkeypatch):
    """A derivation holding the one derivation slot neither delays an upload (the builders'
    slots are others) nor lets a second derivation run: that one is a 503 naming the setting."""
    started, release = threading.Event(), threading.Event()
    real = cache_module.derive_isolated

    def held(model, time_limit_s, memory_mb, printing):
        started.set()
        release.wait(120)
        return real(model, time_limit_s, memory_mb, printing)

    monkeypatch.setattr(cache_module, "derive_isolated", held)
    settings = {"max_concurrent_builds": 1, "max_concurrent_derivations": 1}
    with _client(tmp_path, build_queue_timeout_s=0.5, **settings) as c:
        out: dict = {}
        holder = threading.Thread(
            target=lambda: out.update(held=c.get("/v1/robots/planar_arm/equations"))
        )
        holder.start()
        try:
            assert started.wait(60)
            upload = c.post("/v1/robots", json={"urdf": skewed_arm_urdf(3)})
            assert upload.status_code == 201, upload.text
            second = c.get("/v1/robots/ur5/equations")
            assert second.status_code == 503 and second.json()["code"] == "overloaded"
            assert second.headers["retry-after"]
            assert "ROBODYN_MAX_CONCURRENT_DERIVATIONS" in second.json()["detail"]
        finally:
            release.set()
            holder.join(120)
        assert out["held"].status_code == 200


def test_an_identified_variant_gives_its_parameters_standard_deviations(tmp_path):
    """`POST …/identify` stores a variant; its parametric answer gives each parameter that is
    one of identification's base parameters that one's standard deviation, also after a
    restart (the record keeps the covariance); a robot not identified gives null."""
    from tests.service.dynamics.identification_logs import synthetic_log

    with _client(tmp_path) as c:
        model = c.app.state.registry.get("planar_arm").model  # type: ignore[attr-defined]
        log = synthetic_log(model, seed=4, duration=10.0, rate=100.0, noise=0.05)
        body = {"t": log.t.tolist(), "q": log.q.tolist(), "tau": log.tau.tolist()}
        identified = c.post("/v1/robots/planar_arm/identify", json=body).json()
        variant = identified["robot"]["id"]
        base = identified["base_parameters"]
        named = {
            e.replace(".m_cx", ".mx").replace(".m_cz", ".mz"): s
            for e, s in zip(base["expressions"], base["standard_deviation"], strict=True)
        }
        answer = c.get(f"/v1/robots/{variant}/equations?form=parametric").json()
        plain = c.get("/v1/robots/planar_arm/equations?form=parametric").json()
    assert [p["standard_deviation"] for p in plain["parameters"]] == [None] * 6
    matched = [p for p in answer["parameters"] if p["expression"] in named]
    assert len(matched) >= 2, answer["parameters"]
    for p in matched:
        assert p["standard_deviation"] == pytest.approx(named[p["expression"]], rel=1e-6)
    assert all(p["standard_deviation"] > 0 for p in answer["parameters"])
    registry = Registry(tmp_path, ["planar_arm"])
    registry.load()
    assert registry.get(variant).identified_uncertainty is not None
