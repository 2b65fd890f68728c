"""The client as ROS, ML and controls users hold it: JointState-like inputs with joints left
out, float32/torch inputs and torch answers, progress in chunks, retries of a busy server, and
a user script that type-checks under `mypy --strict`."""

from __future__ import annotations

import asyncio
import importlib.util
import itertools
import re
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
import robodyn
import stamina
from robodyn import AsyncClient, Client, Retry

from tests.client.helpers import API_KEY, Reference, two_link_urdf

HERE = Path(__file__).parent


@dataclass
class JointState:
    """The members of a ROS sensor_msgs/JointState message."""

    name: list[str]
    position: list[float]
    velocity: list[float] = field(default_factory=list)
    effort: list[float] = field(default_factory=list)


# -- ROS-style inputs ---------------------------------------------------------------------


def test_a_joint_state_without_the_gripper_equals_the_full_arrays(
    server: str, reference: Reference
) -> None:
    """panda's JointState without its fingers, filled from neutral: the same answers as the
    full arrays with the fingers at neutral and still."""
    s = reference.states("panda", 2, seed=3)
    with Client(server) as plain, Client(server, fill="neutral") as ros:
        info = plain.robot("panda")
        arm = [j for j in info.joints if "finger" not in j.name]
        q, v, tau = s["q"][0].copy(), s["v"][0].copy(), s["tau"][0].copy()
        fingers = [j for j in info.joints if "finger" in j.name]
        neutral = np.asarray(info.raw["neutral_configuration"])
        for j in fingers:
            q[j.q_slice], v[j.v_slice], tau[j.v_slice] = neutral[j.q_slice], 0.0, 0.0
        state = JointState(
            name=[j.name for j in reversed(arm)],
            position=[float(q[j.q_slice][0]) for j in reversed(arm)],
            velocity=[float(v[j.v_slice][0]) for j in reversed(arm)],
            effort=[float(tau[j.v_slice][0]) for j in reversed(arm)],
        )
        expected = plain.forward_dynamics("panda", q, v, tau)
        assert np.array_equal(ros.forward_dynamics("panda", state, state, state), expected)
        as_dict = dict(zip(state.name, state.position, strict=True))
        assert np.array_equal(ros.gravity("panda", as_dict), plain.gravity("panda", q))
        batch = ros.forward_dynamics("panda", [state, state], [state, state], [state, state])
        assert np.array_equal(batch, np.stack([expected, expected]))
        with pytest.raises(robodyn.DimensionMismatchError) as missing:
            plain.gravity("panda", state)
        assert "panda_finger_joint1" in missing.value.detail
        with pytest.raises(robodyn.InputError, match="no accelerations"):
            ros.inverse_dynamics("panda", state, state, state)
        with pytest.raises(robodyn.InputError, match="velocity has 0 entries"):
            ros.nonlinear_effects("panda", state, JointState(state.name, state.position))


def test_continuous_joints_take_angles_from_a_joint_state(server: str) -> None:
    theta = [0.4, -2.2]
    q = np.array([np.cos(theta[0]), np.sin(theta[0]), np.cos(theta[1]), np.sin(theta[1])])
    with Client(server) as client:
        state = JointState(
            name=["joint2", "joint1"], position=[theta[1], theta[0]], velocity=[0.5, -0.3]
        )
        got = client.nonlinear_effects("double_pendulum_continuous", state, state)
        want = client.nonlinear_effects("double_pendulum_continuous", q, [-0.3, 0.5])
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13)


# -- array-likes and torch ----------------------------------------------------------------


def test_float32_inputs_are_sent_as_their_exact_float64_values(server: str) -> None:
    q32 = np.array([0.1, -1.2, 1.3, 0.2, 0.5, -0.3], dtype=np.float32)
    with Client(server) as client:
        got = client.gravity("ur5", q32)
        assert got.dtype == np.float64
        assert np.array_equal(got, client.gravity("ur5", q32.astype(np.float64)))


def test_torch_inputs_and_torch_answers(server: str, reference: Reference) -> None:
    torch = pytest.importorskip("torch")
    s = reference.states("talos", 30, seed=4)
    with Client(server) as numpy_client, Client(server, array_type="torch") as torch_client:
        q = torch.tensor(s["q"], requires_grad=True)  # detached by the client
        v = torch.tensor(s["v"], dtype=torch.float32)
        expected = numpy_client.coriolis("talos", s["q"], v.numpy().astype(np.float64))
        C, Cv = torch_client.coriolis("talos", q, v)
        assert isinstance(C, torch.Tensor) and C.dtype == torch.float64
        assert np.array_equal(C.numpy(), expected[0]) and np.array_equal(Cv.numpy(), expected[1])
        energy = torch_client.energy("talos", q, v)
        assert isinstance(energy.kinetic_energy, torch.Tensor)
        single = torch_client.gravity("talos", torch.tensor(s["q"][0]))
        assert isinstance(single, torch.Tensor) and single.shape == (s["v"].shape[1],)


def test_jax_inputs(server: str) -> None:
    jnp = pytest.importorskip("jax.numpy")
    q = [0.1, -1.2, 1.3, 0.2, 0.5, -0.3]
    with Client(server) as client:
        np.testing.assert_array_equal(
            client.gravity("ur5", jnp.asarray(q)), client.gravity("ur5", np.float32(q))
        )


def test_array_type_is_checked(monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(robodyn.InputError, match="array_type"):
        Client("http://127.0.0.1:9", array_type="jax")  # type: ignore[arg-type]
    monkeypatch.setitem(sys.modules, "torch", None)  # as if PyTorch were not installed
    with pytest.raises(robodyn.InputError, match="pip install torch"):
        Client("http://127.0.0.1:9", array_type="torch")
    assert Client("http://127.0.0.1:9").base_url  # numpy needs nothing more


# -- progress -----------------------------------------------------------------------------


def test_progress_of_a_batch_in_chunks_is_reported_in_order(
    server: str, reference: Reference
) -> None:
    s = reference.states("ur5", 4500, seed=5)
    seen: list[tuple[int, int]] = []
    with Client(server) as client, Client(server, progress=lambda *a: seen.append(a)) as chunked:
        whole = client.inverse_dynamics_derivatives("ur5", s["q"], s["v"], s["a"])
        parts = chunked.inverse_dynamics_derivatives("ur5", s["q"], s["v"], s["a"])
        assert seen == [(2000, 4500), (4000, 4500), (4500, 4500)]
        assert type(parts) is type(whole)
        for got, want in zip(parts, whole, strict=True):
            assert np.array_equal(got, want)
        seen.clear()
        com = chunked.center_of_mass("ur5", s["q"], s["v"])
        assert [d for d, _ in seen] == [2000, 4000, 4500]
        assert np.array_equal(com.velocity, client.center_of_mass("ur5", s["q"], s["v"]).velocity)
        seen.clear()
        chunked.gravity("ur5", s["q"][:100])  # small: one request, no report
        assert seen == []


def test_the_async_client_reports_progress_too(server: str, reference: Reference) -> None:
    s = reference.states("ur5", 2500, seed=6)
    seen: list[tuple[int, int]] = []

    async def run() -> tuple[np.ndarray, np.ndarray]:
        async with (
            AsyncClient(server) as whole,
            AsyncClient(server, progress=lambda *a: seen.append(a)) as chunked,
        ):
            return (await chunked.gravity("ur5", s["q"]), await whole.gravity("ur5", s["q"]))

    parts, expected = asyncio.run(run())
    assert seen == [(2000, 2500), (2500, 2500)] and np.array_equal(parts, expected)


@pytest.mark.parametrize("batched", [False, True])
# constant torques spin the free wrist many turns past its range: the chunks after are warned of
@pytest.mark.filterwarnings("ignore::robodyn.RobodynWarning")
def test_a_long_simulation_in_chunks_is_the_one_request_trajectory(
    server: str, batched: bool
) -> None:
    q0, v0 = np.array([0.1, -1.2, 1.3, 0.2, 0.5, -0.3]), np.zeros(6)
    if batched:
        q0, v0 = np.stack([q0, -q0]), np.stack([v0, v0 + 0.1])
    schedule = np.sin(np.arange(5001)[:, None] * 1e-3 * np.arange(1, 7))[:5000]
    seen: list[tuple[int, int]] = []
    with Client(server) as client:
        for kwargs in (
            {"controller": {"type": "pd", "kp": 50.0, "kd": 5.0, "q_target": np.zeros(6)}},
            {"tau": schedule} if not batched else {"tau": np.ones(6)},
        ):
            whole = client.simulate("ur5", q0, v0, dt=1e-3, steps=5000, integrator="rk4", **kwargs)
            seen.clear()
            parts = client.simulate(
                "ur5",
                q0,
                v0,
                dt=1e-3,
                steps=5000,
                integrator="rk4",
                progress=lambda *a: seen.append(a),
                **kwargs,
            )
            assert seen == [(2000, 5000), (4000, 5000), (5000, 5000)]
            for got, want in zip(parts, whole, strict=True):
                assert got.shape == want.shape and np.array_equal(got, want)


def test_progress_true_draws_a_tqdm_bar(server: str, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("tqdm")
    with Client(server, progress=True) as client:
        traj = client.simulate("ur5", np.zeros(6), np.zeros(6), dt=1e-3, steps=4500)
    assert traj.q.shape == (4501, 6)
    assert "4500/4500" in capsys.readouterr().err


# -- retries ------------------------------------------------------------------------------


@pytest.fixture
def real_retries() -> Any:
    with stamina.set_testing(False):
        yield


def _busy(times: int, retry_after: str | None, log: list[float]) -> Any:
    """A server answering 503 overloaded `times` times, then the gravity of ur5."""

    def handler(request: httpx.Request) -> httpx.Response:
        log.append(time.monotonic())
        if len(log) <= times:
            headers = {"Retry-After": retry_after} if retry_after is not None else {}
            return httpx.Response(
                503,
                headers=headers,
                json={
                    "type": "about:blank",
                    "title": "Overloaded",
                    "status": 503,
                    "detail": "busy",
                    "code": "overloaded",
                },
            )
        return httpx.Response(200, json={"gravity": [1.0] * 6})

    return handler


def test_retries_honour_retry_after_then_succeed(real_retries: Any) -> None:
    log: list[float] = []
    http = httpx.Client(transport=httpx.MockTransport(_busy(2, "0.3", log)), base_url="http://mock")
    with Client(http_client=http, retry=Retry(attempts=5, timeout=10.0)) as client:
        assert client.gravity("ur5", np.zeros(6)).tolist() == [1.0] * 6
    assert len(log) == 3
    assert all(later - earlier >= 0.3 for earlier, later in itertools.pairwise(log))


def test_retries_stop_within_the_budget(real_retries: Any) -> None:
    log: list[float] = []
    http = httpx.Client(
        transport=httpx.MockTransport(_busy(100, "0.25", log)), base_url="http://mock"
    )
    started = time.monotonic()
    with (
        Client(http_client=http, retry=Retry(attempts=50, timeout=1.0)) as client,
        pytest.raises(robodyn.OverloadedError),
    ):
        client.gravity("ur5", np.zeros(6))
    # Waits of 0.25 s, none of them ending past the 1 s budget: 4 or 5 tries (3 on a loaded
    # machine's late wake-ups). Ignoring the budget would make 50 tries, 12 s: the time bound
    # only has to tell the two apart.
    assert 3 <= len(log) <= 5 and time.monotonic() - started < 6.0
    log.clear()  # a Retry-After past the budget: no waiting for nothing
    http = httpx.Client(
        transport=httpx.MockTransport(_busy(100, "30", log)), base_url="http://mock"
    )
    started = time.monotonic()
    with (
        Client(http_client=http, retry=Retry(attempts=5, timeout=5.0)) as client,
        pytest.raises(robodyn.OverloadedError) as raised,
    ):
        client.gravity("ur5", np.zeros(6))
    assert len(log) == 1 and time.monotonic() - started < 10.0  # not the 30 s asked
    assert raised.value.retry_after == 30.0
    log.clear()  # at most `attempts` tries, with stamina's backoff without Retry-After
    http = httpx.Client(
        transport=httpx.MockTransport(_busy(100, None, log)), base_url="http://mock"
    )
    with (
        Client(
            http_client=http,
            retry=Retry(
                attempts=3, timeout=10.0, wait_initial=0.01, wait_max=0.05, wait_jitter=0.0
            ),
        ) as client,
        pytest.raises(robodyn.OverloadedError),
    ):
        client.gravity("ur5", np.zeros(6))
    assert len(log) == 3


def test_which_failures_are_retried(real_retries: Any) -> None:
    def failing(exc: Exception, then: int = 200) -> tuple[list[str], httpx.Client]:
        calls: list[str] = []

        def handler(request: httpx.Request) -> httpx.Response:
            calls.append(request.method)
            if len(calls) == 1:
                raise exc
            return httpx.Response(then, json={"gravity": [0.0] * 6})

        return calls, httpx.Client(transport=httpx.MockTransport(handler), base_url="http://mock")

    fast = Retry(attempts=3, timeout=5.0, wait_initial=0.01, wait_max=0.01, wait_jitter=0.0)
    for exc in (httpx.ConnectError("refused"), httpx.RemoteProtocolError("closed")):
        calls, http = failing(exc)
        with Client(http_client=http, retry=fast) as client:
            client.gravity("ur5", np.zeros(6))
        assert len(calls) == 2
    calls, http = failing(httpx.ReadTimeout("slow"))  # may be computing: not sent again
    with Client(http_client=http, retry=fast) as client, pytest.raises(robodyn.TimeoutError):
        client.gravity("ur5", np.zeros(6))
    assert len(calls) == 1
    calls, http = failing(httpx.RemoteProtocolError("closed"), then=204)  # maybe deleted
    with Client(http_client=http, retry=fast) as client, pytest.raises(robodyn.TransportError):
        client.delete("arm")
    assert calls == ["DELETE"]
    calls, http = failing(httpx.ConnectError("refused"), then=204)  # surely not sent
    with Client(http_client=http, retry=fast) as client:
        client.delete("arm")
    assert calls == ["DELETE", "DELETE"]
    calls, http = failing(httpx.ConnectError("refused"))
    with Client(http_client=http, retry=None) as client, pytest.raises(robodyn.TransportError):
        client.gravity("ur5", np.zeros(6))
    assert len(calls) == 1


def test_the_async_client_retries_too(real_retries: Any) -> None:
    log: list[float] = []
    handler = _busy(2, "0.2", log)

    async def run() -> list[float]:
        http = httpx.AsyncClient(transport=httpx.MockTransport(handler), base_url="http://mock")
        async with AsyncClient(http_client=http, retry=Retry(timeout=5.0)) as client:
            return (await client.gravity("ur5", np.zeros(6))).tolist()

    assert asyncio.run(run()) == [1.0] * 6 and len(log) == 3
    assert log[2] - log[1] >= 0.2


# -- types --------------------------------------------------------------------------------


def test_a_script_using_every_method_passes_mypy_strict_and_runs(
    server: str, tmp_path: Path
) -> None:
    """tests/client/typed_usage.py type-checks under --strict; a misspelt option does not."""
    bad = tmp_path / "bad_usage.py"
    bad.write_text(
        "from robodyn import Client\n\n"
        "def f(c: Client) -> None:\n"
        "    c.jacobian('ur5', [0.0] * 6, 'tool0', reference_frame='wrold')\n"
        "    c.operational_space('ur5', [0.0] * 6, 'tool0', task='planar')\n"
        "    c.simulate('ur5', [0.0] * 6, [0.0] * 6, dt=0.1, steps=1, "
        "integrator='euler')\n"
    )
    root = HERE.parents[1]
    env = {"PYTHONPATH": f"{root}:{root / 'clients' / 'python' / 'src'}", "PATH": "/usr/bin"}
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "mypy",
            "--strict",
            "--cache-dir",
            str(tmp_path / "cache"),
            "--no-error-summary",
            str(HERE / "typed_usage.py"),
            str(bad),
        ],
        capture_output=True,
        text=True,
        env=env,
        cwd=root,
        timeout=600,
    )
    errors = [line for line in result.stdout.splitlines() if ": error:" in line]
    assert all("bad_usage.py" in line for line in errors), result.stdout
    assert [int(line.split(":")[1]) for line in errors] == [4, 5, 6], result.stdout
    assert "wrold" in result.stdout and "local_world_aligned" in result.stdout
    sys.path.insert(0, str(HERE))
    try:
        import typed_usage
    finally:
        sys.path.remove(str(HERE))
    out = typed_usage.main(server, API_KEY, two_link_urdf(name="typed_usage"))
    assert out["chunks"] == 0.0 and out["mass"] > 0
    assert out["g_ros"] != 0.0
    assert asyncio.run(typed_usage.main_async(server)) != 0.0


# -- the guide ----------------------------------------------------------------------------


def test_the_examples_of_the_client_guide_run(
    server: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """docs/python-client.md: every `<!-- example -->` block (the torch one with torch)."""
    text = (HERE.parents[1] / "docs" / "python-client.md").read_text()
    examples = re.findall(r"<!-- example(: torch)? -->\n```python\n(.*?)```", text, re.S)
    assert len(examples) >= 5
    for torch_only, code in examples:
        if torch_only and importlib.util.find_spec("torch") is None:
            continue
        exec(compile(code.replace("http://127.0.0.1:8000", server), "python-client.md", "exec"), {})
    out = capsys.readouterr().out
    assert "6000/6000 steps" in out and "422 dimension_mismatch ['panda_joint2'" in out
    assert "34.87 shoulder_lift_joint" in out
    assert "4.235 + 2.1*cos(q2)" in out  # the equations example
    assert "('p4', 'elbow.Iyy', 0.735)" in out  # the parametric one


def test_a_request_stopped_at_the_server_deadline_is_not_retried(real_retries: Any) -> None:
    """504 deadline_exceeded: the same request would stop again, so it is raised at once
    (a `DeadlineExceededError`, also a builtin `TimeoutError`)."""
    log: list[float] = []

    def handler(request: httpx.Request) -> httpx.Response:
        log.append(time.monotonic())
        return httpx.Response(
            504,
            json={
                "type": "about:blank",
                "title": "Deadline exceeded",
                "status": 504,
                "detail": "simulate: stopped after 60 s of computing",
                "code": "deadline_exceeded",
                "deadline_s": 60.0,
            },
        )

    http = httpx.Client(transport=httpx.MockTransport(handler), base_url="http://mock")
    with (
        Client(http_client=http, retry=Retry(attempts=5, timeout=10.0)) as client,
        pytest.raises(robodyn.DeadlineExceededError) as raised,
    ):
        client.gravity("ur5", np.zeros(6))
    assert len(log) == 1 and isinstance(raised.value, TimeoutError)
    assert raised.value.body["deadline_s"] == 60.0
