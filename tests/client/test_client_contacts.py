"""Client methods for contacts — contact_dynamics, contact_inverse_dynamics, impulse_dynamics,
simulate(contacts=...) and RobotInfo.contact_frames — sync against a real server (and its
stream), async against the app in process, checked against the server's own functions run in
process; their errors and local input checks."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest
import robodyn
from robodyn import Client
from robodyn._calls import BUILDERS

from service.dynamics.contacts import (
    contact_dynamics,
    contact_inverse_dynamics,
    impulse_dynamics,
)
from service.states import States
from tests.helpers import random_state

SOLES = [{"frame": "left_sole_link", "type": "6d"}, {"frame": "right_sole_link", "type": "6d"}]


@pytest.fixture(scope="module")
def client(server: str) -> Iterator[Client]:
    with Client(server) as c:
        yield c


def _states(registry, n: int | None, seed: int = 0) -> dict[str, np.ndarray]:
    model = registry.catalog["talos"].model
    rng = np.random.default_rng(seed)
    rows = [random_state(model, rng) for _ in range(n or 1)]
    out = {k: np.array([r[i] for r in rows]) for i, k in enumerate(("q", "v", "a"))}
    out["tau"] = out["a"]
    return out if n else {k: v[0] for k, v in out.items()}


def _expected(registry, fn, arrays: dict[str, np.ndarray], **options) -> dict[str, np.ndarray]:
    batched = next(iter(arrays.values())).ndim == 2
    states = States({k: np.atleast_2d(v) for k, v in arrays.items()}, batched)
    out = fn(registry.catalog["talos"], states, **options)
    return {k: states.unbatch(v) for k, v in out.items()}


@pytest.mark.parametrize("n", [None, 3])
def test_contact_methods_return_named_results(client, registry, n):
    s = _states(registry, n)
    got = client.contact_dynamics("talos", s["q"], s["v"], s["tau"], SOLES)
    assert isinstance(got, robodyn.ContactDynamics)
    want = _expected(
        registry, contact_dynamics, {k: s[k] for k in ("q", "v", "tau")}, contacts=SOLES
    )
    np.testing.assert_array_equal(got.a, want["a"])
    np.testing.assert_array_equal(got.contact_forces, want["contact_forces"])
    assert got.contact_forces.shape == ((12,) if n is None else (n, 12))

    inv = client.contact_inverse_dynamics("talos", s["q"], s["v"], s["a"], SOLES)
    assert isinstance(inv, robodyn.ContactInverseDynamics)
    want = _expected(
        registry, contact_inverse_dynamics, {k: s[k] for k in ("q", "v", "a")}, contacts=SOLES
    )
    np.testing.assert_array_equal(inv.tau, want["tau"])
    np.testing.assert_array_equal(inv.contact_forces, want["contact_forces"])
    if n is None:
        assert isinstance(inv.residual, float)
    np.testing.assert_array_equal(inv.residual, want["residual"])

    imp = client.impulse_dynamics("talos", s["q"], s["v"], SOLES, restitution=0.5)
    assert isinstance(imp, robodyn.ImpulseDynamics)
    want = _expected(
        registry, impulse_dynamics, {k: s[k] for k in ("q", "v")}, contacts=SOLES, restitution=0.5
    )
    np.testing.assert_array_equal(imp.v, want["v"])
    np.testing.assert_array_equal(imp.contact_impulses, want["contact_impulses"])
    v_after, impulses = imp  # a named tuple
    assert v_after is imp.v and impulses is imp.contact_impulses


def test_robot_info_suggests_the_feet_and_they_stand(client, registry):
    """talos's suggested contacts carry its weight at its reference posture."""
    info = client.robot("talos")
    assert info.contact_frames == SOLES
    assert client.robot("ur5").contact_frames == []
    zero = np.zeros(info.nv)
    held = client.contact_inverse_dynamics(
        "talos", info.default_configuration, zero, zero, info.contact_frames
    )
    weight = info.total_mass * 9.81
    assert held.residual <= 1e-9 * weight
    assert held.contact_forces.reshape(2, 6)[:, 2].sum() == pytest.approx(weight, rel=1e-9)


def test_simulate_with_contacts_reports_the_drift(client, registry):
    info = client.robot("talos")
    q0 = info.default_configuration
    traj = client.simulate(
        "talos",
        q0,
        np.zeros(info.nv),
        dt=1e-3,
        steps=20,
        contacts=SOLES,
        controller={
            "type": "pd",
            "kp": 0.0,
            "kd": 0.0,
            "q_target": q0,
            "gravity_compensation": True,
        },
    )
    assert isinstance(traj, robodyn.ContactTrajectory)
    assert traj.constraint_drift.shape == (21,) and traj.q.shape == (21, info.nq)
    assert traj.constraint_drift.max() < 1e-10
    plain = client.simulate("talos", q0, np.zeros(info.nv), dt=1e-3, steps=2)
    assert type(plain) is robodyn.Trajectory


def test_stream_offers_the_contact_methods(client, registry):
    s = _states(registry, None, seed=4)
    with client.stream("talos") as stream:
        got = stream.contact_dynamics(s["q"], s["v"], s["tau"], SOLES)
        with pytest.raises(robodyn.UnknownFrameError):
            stream.impulse_dynamics(s["q"], s["v"], [{"frame": "nope", "type": "6d"}])
        again = stream.contact_dynamics(s["q"], s["v"], s["tau"], SOLES)
    want = client.contact_dynamics("talos", s["q"], s["v"], s["tau"], SOLES)
    np.testing.assert_array_equal(got.a, want.a)
    np.testing.assert_array_equal(again.contact_forces, want.contact_forces)


def test_server_errors_raise_their_classes(client):
    q = np.zeros(6)
    with pytest.raises(robodyn.UnknownFrameError, match="no_such_frame"):
        client.contact_dynamics("ur5", q, q, q, [{"frame": "no_such_frame"}])
    with pytest.raises(robodyn.SingularConfigurationError, match="tool0"):
        client.contact_dynamics(
            "ur5",
            q + 0.3,
            q,
            q,
            [{"frame": "tool0", "type": "6d"}, {"frame": "wrist_3_link", "type": "6d"}],
        )
    with pytest.raises(robodyn.SingularConfigurationError, match="world"):
        client.impulse_dynamics("ur5", q, q, ["base_link"])
    # damping answers the singular set
    got = client.contact_dynamics(
        "ur5",
        q + 0.3,
        q,
        q,
        [{"frame": "tool0", "type": "6d"}, {"frame": "wrist_3_link", "type": "6d"}],
        damping=1e-6,
    )
    assert got.contact_forces.shape == (12,)


@pytest.mark.parametrize(
    "contacts",
    [
        [],
        "tool0",
        [{"frame": 3}],
        [{"frame": "tool0", "type": "line"}],
        [{"frame": "tool0", "mu": 1.0}],
        [7],
    ],
)
def test_bad_contacts_are_refused_locally(contacts):
    with pytest.raises(robodyn.InputError):
        BUILDERS["contact_dynamics"]("ur5", np.zeros(6), np.zeros(6), np.zeros(6), contacts)


@pytest.mark.parametrize(
    "options",
    [{"restitution": 2.0}, {"restitution": -1.0}, {"damping": float("nan")}, {"damping": True}],
)
def test_bad_options_are_refused_locally(options):
    with pytest.raises(robodyn.InputError):
        BUILDERS["impulse_dynamics"]("ur5", np.zeros(6), np.zeros(6), ["tool0"], **options)


@pytest.mark.anyio
async def test_async_client_matches(aclient, registry):
    s = _states(registry, 2, seed=9)
    got = await aclient.contact_inverse_dynamics("talos", s["q"], s["v"], s["a"], SOLES)
    want = _expected(
        registry, contact_inverse_dynamics, {k: s[k] for k in ("q", "v", "a")}, contacts=SOLES
    )
    np.testing.assert_array_equal(got.tau, want["tau"])
    np.testing.assert_array_equal(got.residual, want["residual"])
    imp = await aclient.impulse_dynamics("talos", s["q"], s["v"], SOLES)
    np.testing.assert_array_equal(
        imp.v,
        _expected(registry, impulse_dynamics, {k: s[k] for k in ("q", "v")}, contacts=SOLES)["v"],
    )
    fwd = await aclient.contact_dynamics("talos", s["q"], s["v"], s["tau"], SOLES)
    assert fwd.a.shape == (2, registry.catalog["talos"].nv)
    traj = await aclient.simulate(
        "talos", s["q"][0], np.zeros(fwd.a.shape[1]), dt=1e-3, steps=3, contacts=SOLES
    )
    assert traj.constraint_drift.shape == (4,)
    with pytest.raises(robodyn.UnknownFrameError):
        await aclient.contact_dynamics("talos", s["q"], s["v"], s["tau"], ["nope"])
