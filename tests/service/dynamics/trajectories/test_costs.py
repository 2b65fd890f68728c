"""The cost limits of trajectory-check and retime (ROBODYN_MAX_TRAJECTORY_WORK,
ROBODYN_MAX_RETIME_WORK): the work counted from the request's sizes as the contract states it
(evaluated points × nv; path intervals × nv × limited quantities), the largest request of a
limit admitted and the next one refused with a 422 naming the limit, the factors and what fits,
decided before anything is computed; the evaluated points taken in chunks, with the answer of
the whole motion and no array of all the points held; the sizes the tests and docs use admitted
under the defaults."""

from __future__ import annotations

import tracemalloc
from collections.abc import Iterator

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient
from scipy.interpolate import CubicSpline

from service.dynamics.trajectories import check, check_trajectory, retiming
from service.errors import InvalidInput
from service.main import create_app
from service.registry import Registry
from service.settings import Settings

UR5_NV = 6
CHECK_LIMIT = UR5_NV * 1000 + 3  # 1,000 evaluated points of a UR5
RETIME_LIMIT = (800 + 16 * 9) * UR5_NV * 2 + 5  # a UR5 path of 10 waypoints, velocity and effort
HELD = np.array([0.0, -1.57, 1.57, 0.0, 0.0, 0.0])  # gravity needs 0.36 of the torque limits


@pytest.fixture(scope="module")
def registry(tmp_path_factory: pytest.TempPathFactory) -> Registry:
    registry = Registry(tmp_path_factory.mktemp("trajectory-costs"), ["ur5", "panda", "xarm7"])
    registry.load()
    return registry


@pytest.fixture(scope="module")
def api(registry: Registry) -> Iterator[TestClient]:
    settings = Settings(
        data_dir=registry.store.dir.parent,
        catalog="ur5,panda,xarm7",
        max_trajectory_work=CHECK_LIMIT,
        max_retime_work=RETIME_LIMIT,
    )
    with TestClient(
        create_app(settings, registry=registry), raise_server_exceptions=False
    ) as client:
        yield client


def _motion(n: int, nq: int = UR5_NV) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 0.01 * n, n)
    return t, 0.3 * np.sin(t[:, None] + np.linspace(0.0, 1.0, nq)[None, :])


@pytest.mark.parametrize(("k", "given"), [(4, False), (1, False), (7, True)])
def test_the_largest_check_within_the_limit_is_admitted_and_one_sample_more_refused(
    api: TestClient, k: int, given: bool
) -> None:
    """The contract: N samples are (N − 1) k + 1 evaluated points where v and a come from the
    spline, else N; the work is points × nv."""
    step = 1 if given else k
    largest = (CHECK_LIMIT // UR5_NV - 1) // step + 1
    answers = []
    for n in (largest, largest + 1):
        t, q = _motion(n)
        body = {"t": t.tolist(), "q": q.tolist(), "samples_per_interval": k}
        if given:
            body.update(v=np.zeros_like(q).tolist(), a=np.zeros_like(q).tolist())
        answers.append(api.post("/v1/robots/ur5/trajectory-check", json=body))
    admitted, refused = answers
    assert admitted.status_code == 200, admitted.text
    assert refused.status_code == 422, refused.text
    problem = refused.json()
    assert problem["code"] == "validation_error"
    assert problem["max_work"] == CHECK_LIMIT
    assert problem["work"] == (largest * step + 1) * UR5_NV  # (N − 1) k + 1 with N = largest + 1
    assert problem["largest_samples"] == largest
    detail = problem["detail"]
    assert "ROBODYN_MAX_TRAJECTORY_WORK" in detail and f"{CHECK_LIMIT:,}" in detail
    assert f"at most {largest:,} samples" in detail and "nv = 6" in detail
    if step > 1:
        assert f"{k} points per interval" in detail and "samples_per_interval" in detail


def test_the_largest_retime_within_the_limit_is_admitted_and_one_waypoint_more_refused(
    api: TestClient,
) -> None:
    """The contract: K waypoints give a grid of at most 800 + 16 (K − 1) intervals; the work is
    intervals × nv × limited quantities (velocity and effort; acceleration where given)."""
    rng = np.random.default_rng(3)
    path = HELD + np.cumsum(rng.uniform(-0.05, 0.05, (11, 6)), axis=0)
    admitted = api.post("/v1/robots/ur5/retime", json={"waypoints": path[:10].tolist()})
    assert admitted.status_code == 200, admitted.text
    refused = api.post("/v1/robots/ur5/retime", json={"waypoints": path.tolist()})
    assert refused.status_code == 422, refused.text
    problem = refused.json()
    assert problem["code"] == "validation_error" and problem["max_work"] == RETIME_LIMIT
    assert problem["work"] == (800 + 16 * 10) * UR5_NV * 2 and problem["largest_waypoints"] == 10
    assert "ROBODYN_MAX_RETIME_WORK" in problem["detail"]
    assert "at most 10 waypoints" in problem["detail"] and "velocity, effort" in problem["detail"]
    # acceleration limits are a third limited quantity: not even two waypoints fit here
    accelerated = api.post(
        "/v1/robots/ur5/retime",
        json={"waypoints": path[:2].tolist(), "limits": {"acceleration": [5.0] * 6}},
    )
    assert accelerated.status_code == 422, accelerated.text
    problem = accelerated.json()
    assert problem["work"] == (800 + 16) * UR5_NV * 3 and problem["largest_waypoints"] == 0
    assert "not even two waypoints" in problem["detail"]
    assert "velocity, effort, acceleration" in problem["detail"]


@pytest.mark.parametrize("count", [2, 3, 10, 57, 400, 1000])
def test_a_paths_grid_has_at_most_the_intervals_its_cost_counts(count: int) -> None:
    """Segments of very different lengths (some far shorter than 1/800 of the path, some most
    of it): the grid never has more than 800 + 16 (K − 1) intervals."""
    rng = np.random.default_rng(count)
    lengths = rng.choice([0.1, 1.0, 50.0], size=count - 1) * rng.uniform(0.5, 1.5, count - 1)
    steps = rng.normal(size=(count - 1, 6))
    steps *= (lengths / np.linalg.norm(steps, axis=1))[:, None]
    waypoints = np.concatenate([np.zeros((1, 6)), np.cumsum(steps, axis=0)])
    path = retiming.WaypointPath(waypoints, 6)
    assert len(path.knots) == count  # none merged
    assert len(retiming.gridpoints(path)) - 1 <= 800 + 16 * (count - 1)
    assert retiming.path_intervals(count) == 800 + 16 * (count - 1)


def test_a_refusal_computes_nothing(registry: Registry, monkeypatch: pytest.MonkeyPatch) -> None:
    """Over their limits a check and a retiming are refused before the spline, RNEA or the
    path's sampling run."""

    def computed(*args: object, **kwargs: object) -> None:
        raise AssertionError("computed before refusing")

    monkeypatch.setattr(check, "SampleSpline", computed)
    monkeypatch.setattr(check, "inverse_dynamics_with_loads", computed)
    monkeypatch.setattr(retiming, "sample_path", computed)
    robot = registry.get("ur5")
    t, q = _motion(2000)
    with pytest.raises(InvalidInput, match="ROBODYN_MAX_TRAJECTORY_WORK"):
        check.check_samples(robot, t, q, None, None, samples_per_interval=64, max_work=10**5)
    with pytest.raises(InvalidInput, match="ROBODYN_MAX_RETIME_WORK"):
        retiming.retime(robot, np.stack([HELD, HELD + 0.1, HELD]), max_work=1000)


def _runs(t: np.ndarray, values: np.ndarray, limit: float) -> list[tuple[float, float, float]]:
    """(t_start, t_end, worst) of every run of |values| beyond limit (1e-9 relative)."""
    over = np.abs(values) > limit * (1 + 1e-9)
    out, i = [], 0
    while i < len(values):
        if over[i]:
            j = i
            while j + 1 < len(values) and over[j + 1]:
                j += 1
            run = values[i : j + 1]
            out.append((float(t[i]), float(t[j]), float(run[np.argmax(np.abs(run))])))
            i = j + 1
        else:
            i += 1
    return out


def test_a_check_in_chunks_reports_the_whole_motion(
    registry: Registry, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Chunks of one interval (8 points): runs of violations across many chunks are one entry
    each, equal to the runs over every evaluated point computed here (the spline through the
    samples, `pin.rnea` point by point); τ, v and the peaks equal the check's in one chunk."""
    robot = registry.get("ur5")
    k, n = 8, 31
    t = np.linspace(0.0, 1.5, n)
    q = np.outer(np.sin(2.0 * t), [0.4, -0.9, 1.1, 0.3, -0.5, 0.8])
    scales = {"velocity_scale": 0.3, "effort_scale": 0.05}
    whole = check_trajectory(robot, t, q, samples_per_interval=k, **scales)
    monkeypatch.setattr(check, "chunk_points", lambda nv: 5)
    chunked = check_trajectory(robot, t, q, samples_per_interval=k, **scales)
    np.testing.assert_array_equal(chunked.tau, whole.tau)
    np.testing.assert_array_equal(chunked.v, whole.v)
    assert chunked.violations == whole.violations
    for part, one in zip(chunked.joints, whole.joints, strict=True):  # integrals: rounding
        assert part.pop("rms_effort") == pytest.approx(one.pop("rms_effort"), rel=1e-12)
        assert part == one
    assert chunked.work == pytest.approx(whole.work, rel=1e-12)

    t_eval = np.concatenate(
        [np.linspace(t[i], t[i + 1], k, endpoint=False) for i in range(n - 1)] + [t[-1:]]
    )
    spline = CubicSpline(t, q, bc_type="not-a-knot")
    q_eval, v_eval, a_eval = spline(t_eval), spline(t_eval, 1), spline(t_eval, 2)
    q_eval[::k] = q
    data = robot.model.createData()
    tau_eval = np.array(
        [pin.rnea(robot.model, data, *x) for x in zip(q_eval, v_eval, a_eval, strict=True)]
    )
    model = robot.model
    expected = []
    for j in range(6):
        name = model.names[j + 1]
        for kind, values, limit in (
            ("effort", tau_eval[:, j], model.effortLimit[j] * scales["effort_scale"]),
            ("velocity", v_eval[:, j], model.velocityLimit[j] * scales["velocity_scale"]),
        ):
            expected += [(name, kind, *run) for run in _runs(t_eval, values, limit)]
    found = [
        (x["joint"], x["kind"], x["t_start"], x["t_end"], x["worst"]) for x in chunked.violations
    ]
    assert len(expected) >= 6 and any(end - start > 0.1 for _, _, start, end, _ in expected)
    found.sort(key=lambda x: x[:4])
    expected.sort(key=lambda x: x[:4])
    assert [x[:2] for x in found] == [x[:2] for x in expected]
    np.testing.assert_allclose(
        [x[2:] for x in found], [x[2:] for x in expected], rtol=1e-9, atol=1e-9
    )


def test_a_check_holds_no_array_of_all_its_points(registry: Registry) -> None:
    """10,000 UR5 samples at 64 points per interval: 640,000 points, 31 MB an array of all of
    them; the check's peak of traced memory stays under one such array."""
    robot = registry.get("ur5")
    t, q = _motion(10_000)
    points = (len(t) - 1) * 64 + 1
    tracemalloc.start()
    try:
        result = check_trajectory(robot, t, q, samples_per_interval=64)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert result.tau.shape == (10_000, 6)
    assert peak < points * robot.nv * 8, f"{peak / 1e6:.1f} MB"


# Requests of the sizes the tests and the documentation use: (robot, samples, k, v and a given)
CHECKS = [
    ("ur5", 30_000, 32, False),  # the progress stream stopped by a disconnect
    ("ur5", 20_000, 32, False),  # the progress stream
    ("ur5", 100_000, 2, False),  # the largest JSON check's liveness
    ("ur5", 10_000, 16, False),  # a long check's liveness
    ("ur5", 15_626, 64, False),  # a UR5's most evaluated points (1,000,000)
    ("xarm7", 10_000, 4, True),  # the benchmark
    ("talos", 100_000, 4, True),  # the largest batch of a humanoid with v and a
]


@pytest.mark.parametrize(("robot", "samples", "k", "given"), CHECKS)
def test_the_default_limit_admits_the_checks_the_tests_and_docs_send(
    robot: str, samples: int, k: int, given: bool
) -> None:
    nv = {"ur5": 6, "xarm7": 7, "talos": 38}[robot]
    points = samples if given else (samples - 1) * k + 1
    assert points * nv <= Settings().max_trajectory_work
    check.admit_check(samples, k, not given, nv, Settings().max_trajectory_work)


@pytest.mark.parametrize(("nv", "waypoints"), [(6, 1000), (7, 1000), (9, 1000)])
def test_the_default_limit_admits_the_retimings_the_tests_and_docs_send(
    nv: int, waypoints: int
) -> None:
    """The arms' longest paths (1,000 waypoints, the route's cap), acceleration limits given."""
    assert (800 + 16 * (waypoints - 1)) * nv * 3 <= Settings().max_retime_work
    retiming.admit_retime(waypoints, nv, True, Settings().max_retime_work)


def test_the_defaults_bound_a_126_joint_tree() -> None:
    """What the defaults admit on the largest upload (126 joints): at most 79,365 evaluated
    points (19,842 samples at the default 4 points per interval), and 75 waypoints (33 with
    acceleration limits), as docs/trajectories.md states."""
    defaults = Settings()
    with pytest.raises(InvalidInput) as refused:
        check.admit_check(66_576, 4, True, 126, defaults.max_trajectory_work)
    assert refused.value.extra["largest_samples"] == 19_842
    with pytest.raises(InvalidInput) as refused:
        retiming.admit_retime(1000, 126, False, defaults.max_retime_work)
    assert refused.value.extra["largest_waypoints"] == 75
    with pytest.raises(InvalidInput) as refused:
        retiming.admit_retime(1000, 126, True, defaults.max_retime_work)
    assert refused.value.extra["largest_waypoints"] == 33
