"""The client's binary form for large batches, and its WebSocket streams, against a real server."""

from __future__ import annotations

import asyncio
from pathlib import Path

import httpx
import numpy as np
import pytest
import robodyn
from robodyn import AsyncClient, Client, core

from tests.client.helpers import ATOL, RTOL, Reference

QUANTITIES = {
    "mass_matrix": ("q",),
    "gravity": ("q",),
    "coriolis": ("q", "v"),
    "nonlinear_effects": ("q", "v"),
    "inverse_dynamics": ("q", "v", "a"),
    "forward_dynamics": ("q", "v", "tau"),
}


def _as_tuple(x):
    return x if isinstance(x, tuple) else (x,)


@pytest.mark.parametrize("quantity", list(QUANTITIES))
def test_binary_and_json_answers_are_bit_identical(
    server: str, reference: Reference, quantity: str
) -> None:
    states = reference.states("talos", 80, seed=3)
    inputs = [states[name] for name in QUANTITIES[quantity]]
    with Client(server, binary=True) as b, Client(server, binary=False) as j:
        got_binary = _as_tuple(getattr(b, quantity)("talos", *inputs))
        got_json = _as_tuple(getattr(j, quantity)("talos", *inputs))
        single = _as_tuple(getattr(b, quantity)("talos", *(x[5] for x in inputs)))
    want = _as_tuple(getattr(reference, quantity)("talos", *inputs))
    for gb, gj, s, w in zip(got_binary, got_json, single, want, strict=True):
        np.testing.assert_array_equal(gb, gj)
        np.testing.assert_array_equal(s, gj[5])
        np.testing.assert_allclose(gb, w, rtol=RTOL, atol=ATOL)
        assert gb.flags.writeable


def test_the_client_chooses_the_binary_form_for_large_batches(app) -> None:
    seen: list[httpx.Request] = []
    transport = httpx.ASGITransport(app=app)

    async def run() -> tuple[np.ndarray, np.ndarray]:
        async def record(request: httpx.Request) -> None:
            seen.append(request)

        async with (
            httpx.AsyncClient(
                transport=transport, base_url="http://robodyn", event_hooks={"request": [record]}
            ) as http,
            AsyncClient(http_client=http) as client,
        ):
            small = await client.gravity("ur5", np.zeros((2, 6)))
            large_n = core.BINARY_FROM // 6 + 1
            large = await client.gravity("ur5", np.zeros((large_n, 6)))
            return small, large

    small, large = asyncio.run(run())
    assert seen[0].headers["content-type"] == "application/json"
    assert seen[1].headers["content-type"] == robodyn.binary.MEDIA_TYPE
    np.testing.assert_array_equal(large[0], small[0])


def test_stream_sync(server: str, reference: Reference) -> None:
    states = reference.states("ur5", 5, seed=1)
    want = reference.inverse_dynamics("ur5", states["q"], states["v"], states["a"])
    with Client(server) as client, client.stream("ur5") as s:
        for i in range(5):
            q, v, a = states["q"][i], states["v"][i], states["a"][i]
            np.testing.assert_allclose(s.inverse_dynamics(q, v, a), want[i], rtol=RTOL, atol=ATOL)
        C, Cv = s.coriolis(states["q"], states["v"])  # a batch over the stream
        assert C.shape == (5, 6, 6) and Cv.shape == (5, 6)
        with pytest.raises(robodyn.DimensionMismatchError):
            s.gravity(np.zeros(5))
        np.testing.assert_allclose(
            s.mass_matrix(states["q"][0]),
            reference.mass_matrix("ur5", states["q"][:1])[0],
            rtol=RTOL,
            atol=ATOL,
        )  # still open after the error


def test_stream_binary_and_async(server: str, reference: Reference) -> None:
    states = reference.states("talos", 100, seed=4)

    async def run() -> np.ndarray:
        async with AsyncClient(server) as client, client.stream("talos") as s:
            return await s.forward_dynamics(states["q"], states["v"], states["tau"])

    a = asyncio.run(run())
    with Client(server, binary=False) as j:
        np.testing.assert_array_equal(
            a, j.forward_dynamics("talos", states["q"], states["v"], states["tau"])
        )


def test_stream_of_an_unknown_robot_raises(server: str) -> None:
    with Client(server) as client:
        with pytest.raises(robodyn.RobotNotFoundError) as raised:
            client.stream("no_such_robot")
        assert "GET /v1/robots" in raised.value.detail


def test_a_stream_to_no_server_is_a_transport_error() -> None:
    with Client("http://127.0.0.1:9") as client, pytest.raises(robodyn.TransportError):
        client.stream("ur5")


def test_the_binary_format_example_in_the_docs_runs(server: str, reference: Reference) -> None:
    doc = (Path(__file__).parents[2] / "docs" / "binary-format.md").read_text()
    code = doc.split("```python\n", 1)[1].split("```", 1)[0]
    scope: dict = {}
    exec(code.replace("http://127.0.0.1:8000", server), scope)
    M = np.array(scope["values"]).reshape(3, 6, 6)
    q = np.array(scope["q"])
    np.testing.assert_allclose(M, reference.mass_matrix("ur5", q), rtol=RTOL, atol=ATOL)


TASK_SPACE_CALLS = {
    "mass_matrix_inverse": lambda c, q, v: (c.mass_matrix_inverse("talos", q),),
    "energy": lambda c, q, v: (
        lambda e: (e.kinetic_energy, e.potential_energy, e.mechanical_energy)
    )(c.energy("talos", q, v)),
    "center_of_mass": lambda c, q, v: (lambda r: (r.position, r.jacobian, r.velocity))(
        c.center_of_mass("talos", q, v)
    ),
    "jacobian": lambda c, q, v: (lambda r: (r.jacobian, r.jacobian_time_variation))(
        c.jacobian("talos", q, "gripper_left_joint", reference_frame="local", v=v)
    ),
    "operational_space": lambda c, q, v: (
        lambda r: (r.inertia, r.jacobian, r.dynamically_consistent_inverse, r.gravity, r.coriolis)
    )(c.operational_space("talos", q, "gripper_left_joint", v=v, task="linear", damping=1e-3)),
}


@pytest.mark.parametrize("quantity", list(TASK_SPACE_CALLS))
def test_task_space_quantities_in_binary_equal_json_and_stream(
    server: str, reference: Reference, quantity: str
) -> None:
    """Quantities with options (frame, task, damping) travel in the binary header's fields:
    the binary answer equals the JSON one bit for bit, and the stream gives the same."""
    states = reference.states("talos", 40, seed=11)
    q, v = states["q"], states["v"]
    call = TASK_SPACE_CALLS[quantity]
    with Client(server, binary=True) as b, Client(server, binary=False) as j:
        got_binary, got_json = call(b, q, v), call(j, q, v)
        with b.stream("talos") as s:
            streamed = call(_StreamAsClient(s), q[7], v[7])
    for gb, gj, s1 in zip(got_binary, got_json, streamed, strict=True):
        assert isinstance(gb, np.ndarray) and gb.shape[0] == 40
        np.testing.assert_array_equal(gb, gj)
        np.testing.assert_allclose(s1, gj[7], rtol=1e-12, atol=1e-12)


class _StreamAsClient:
    """A stream's methods with the client's signature (the robot id is dropped)."""

    def __init__(self, stream: object) -> None:
        self._stream = stream

    def __getattr__(self, name: str):
        method = getattr(self._stream, name)
        return lambda robot_id, *args, **kwargs: method(*args, **kwargs)


PART_7_CALLS = {
    "inverse_dynamics_derivatives": lambda c, s: tuple(
        c.inverse_dynamics_derivatives("talos", s["q"], s["v"], s["a"])
    ),
    "forward_dynamics_derivatives": lambda c, s: tuple(
        c.forward_dynamics_derivatives("talos", s["q"], s["v"], s["tau"])
    ),
    "centroidal": lambda c, s: tuple(c.centroidal("talos", s["q"], s["v"])),
    "inverse_dynamics_with_a_wrench": lambda c, s: (
        c.inverse_dynamics(
            "talos",
            s["q"],
            s["v"],
            s["a"],
            external_forces=[
                {
                    "frame": "gripper_left_joint",
                    "wrench": [1.0, -2.0, 3.0, 0.1, 0.2, -0.3],
                    "reference_frame": "local",
                }
            ],
        ),
    ),
}


@pytest.mark.parametrize("quantity", list(PART_7_CALLS))
def test_derivatives_centroidal_and_wrenches_in_binary_and_on_the_stream(
    server: str, reference: Reference, quantity: str
) -> None:
    states = reference.states("talos", 12, seed=5)
    call = PART_7_CALLS[quantity]
    with Client(server, binary=True) as b, Client(server, binary=False) as j:
        got_binary, got_json = call(b, states), call(j, states)
        with b.stream("talos") as s:
            streamed = call(_StreamAsClient(s), {k: x[3] for k, x in states.items()})
    for gb, gj, s1 in zip(got_binary, got_json, streamed, strict=True):
        assert gb.shape[0] == 12
        np.testing.assert_array_equal(gb, gj)
        np.testing.assert_allclose(s1, gj[3], rtol=1e-12, atol=1e-12)


def test_joint_name_inputs_on_the_stream(server: str) -> None:
    """Inputs keyed by joint name, in any order, are understood on the stream too."""
    with Client(server) as client, client.stream("ur5") as s:
        names = [j.name for j in client.robot("ur5").joints if j.nv > 0]
        q = np.linspace(-1.0, 1.0, len(names))
        by_name = {name: float(x) for name, x in reversed(list(zip(names, q, strict=True)))}
        np.testing.assert_array_equal(s.gravity(by_name), client.gravity("ur5", q))
