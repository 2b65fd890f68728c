"""`payloads=` on every computing method: the client sends `"payloads": [...]` in the JSON body
or in the binary form's metadata, in every chunk of a long batch or simulation and in stream
messages; nothing when none are given; bad payloads are refused before anything is sent."""

from __future__ import annotations

import contextlib
import json
from typing import Any

import httpx
import numpy as np
import pytest
import robodyn
from robodyn import Client, Payload, binary
from robodyn._calls import BUILDERS, STREAMED
from robodyn.stream import message

from tests.client.test_client_contract import ANSWERS, ARGS, KWARGS, TRAJECTORY

TOOL = Payload(
    "tool0", 3.0, center_of_mass=np.array([0.0, 0.0, 0.05]), inertia=np.diag([0.01, 0.02, 0.03])
)
GRIPPER = {"frame": "wrist_3_link", "mass": 0.5}  # a point mass at the frame's origin
SENT = [
    {
        "frame": "tool0",
        "mass": 3.0,
        "center_of_mass": [0.0, 0.0, 0.05],
        "inertia": [[0.01, 0.0, 0.0], [0.0, 0.02, 0.0], [0.0, 0.0, 0.03]],
    },
    {
        "frame": "wrist_3_link",
        "mass": 0.5,
        "center_of_mass": [0.0, 0.0, 0.0],
        "inertia": [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]],
    },
]


def sized(body: dict[str, Any], simulate: bool) -> dict[str, Any]:
    """A 1-DoF robot's answer of the size the request asks for (states, steps)."""
    if simulate:
        n = body["steps"] + 1
        return {"t": [0.0] * n, "q": [[0.0]] * n, "v": [[0.0]] * n, "mechanical_energy": [0.0] * n}
    return {"gravity": [[0.0]] * len(body["q"])}


class Recorder:
    """A mock server that answers every route and keeps the requests' bodies."""

    def __init__(self, answer: Any = None) -> None:
        self.bodies: list[dict[str, Any]] = []
        self.answer = answer

    def __call__(self, request: httpx.Request) -> httpx.Response:
        if request.headers.get("content-type") == binary.MEDIA_TYPE:
            self.bodies.append(binary.decode(bytearray(request.content)))
        else:
            self.bodies.append(json.loads(request.content or b"{}"))
        simulate = request.url.path.endswith("/simulate")
        if self.answer is not None:
            return httpx.Response(200, json=self.answer(self.bodies[-1], simulate))
        return httpx.Response(200, json={**ANSWERS, **TRAJECTORY} if simulate else ANSWERS)

    def client(self, **options: Any) -> Client:
        http = httpx.Client(transport=httpx.MockTransport(self), base_url="http://mock")
        return Client(http_client=http, **options)


@pytest.mark.parametrize("use_binary", [False, True])
def test_every_computing_method_sends_its_payloads(use_binary: bool) -> None:
    mock = Recorder()
    with mock.client(binary=use_binary) as client:
        for name in STREAMED:
            with contextlib.suppress(robodyn.ResponseFormatError):  # mock answers' shapes
                getattr(client, name)(*ARGS[name], **KWARGS.get(name, {}), payloads=[TOOL, GRIPPER])
            assert mock.bodies[-1]["payloads"] == SENT, name
            with contextlib.suppress(robodyn.ResponseFormatError):
                getattr(client, name)(*ARGS[name], **KWARGS.get(name, {}))
            assert "payloads" not in mock.bodies[-1], name


def test_an_empty_list_sends_nothing() -> None:
    mock = Recorder()
    with mock.client() as client:
        client.gravity("r", [0.0], payloads=[])
    assert mock.bodies == [{"q": [0.0]}]


def test_every_chunk_of_a_long_batch_or_simulation_carries_the_payloads() -> None:
    mock, done = Recorder(sized), []
    chunk = robodyn.progress.CHUNK_STATES
    with mock.client(progress=lambda n, total: done.append(n), binary=False) as client:
        g = client.gravity("r", np.zeros((2 * chunk + 1, 1)), payloads=[TOOL])
        assert g.shape == (2 * chunk + 1, 1) and done == [chunk, 2 * chunk, 2 * chunk + 1]
        assert len(mock.bodies) == 3
        assert all(body["payloads"] == SENT[:1] for body in mock.bodies)
        mock.bodies.clear()
        steps = robodyn.progress.CHUNK_STEPS + 1
        traj = client.simulate("r", [0.0], [0.0], dt=1e-3, steps=steps, payloads=[GRIPPER])
        assert traj.q.shape == (steps + 1, 1) and len(mock.bodies) == 2
        assert all(body["payloads"] == SENT[1:] for body in mock.bodies)


def test_stream_messages_carry_the_payloads() -> None:
    call = BUILDERS["inverse_dynamics"]("r", [0.0], [0.0], [0.0], payloads=[TOOL])
    sent = json.loads(message(call, None))
    assert sent["quantity"] == "inverse-dynamics" and sent["payloads"] == SENT[:1]
    large = BUILDERS["mass_matrix"]("r", np.zeros((5000, 1)), payloads=[GRIPPER])
    assert binary.decode(bytearray(message(large, None)))["payloads"] == SENT[1:]


def test_a_payload_is_checked_when_made_and_compares_by_value() -> None:
    assert (
        Payload(
            "tool0", 3, center_of_mass=np.array([0, 0, 0.05]), inertia=np.diag([0.01, 0.02, 0.03])
        )
        == TOOL
    )
    assert len({TOOL, Payload("tool0", 3.0, (0.0, 0.0, 0.05), np.diag([0.01, 0.02, 0.03]))}) == 1
    assert TOOL.to_json() == SENT[0]
    with pytest.raises(robodyn.InputError, match="Payload: mass must be a finite number"):
        Payload("tool0", float("nan"))
    with pytest.raises(robodyn.InputError, match="Payload: frame must be a frame name"):
        Payload("", 1.0)
    with pytest.raises(robodyn.InputError, match=r"center_of_mass must have shape \(3,\)"):
        Payload("tool0", 1.0, center_of_mass=(0.0, 0.1))
    with pytest.raises(robodyn.InputError, match="inertia must be finite"):
        Payload("tool0", 1.0, inertia=np.full((3, 3), np.inf))


@pytest.mark.parametrize(
    ("payloads", "match"),
    [
        (TOOL, "a list of Payload"),
        ({"frame": "tool0", "mass": 1.0}, "a list of Payload"),
        ([{"frame": "tool0", "mass": float("nan")}], r"payloads\[0\]: mass must be a finite"),
        ([{"frame": "", "mass": 1.0}], r"payloads\[0\]: frame must be a frame name"),
        ([{"frame": "tool0", "mass": 1.0, "center_of_mass": [0.0, 0.1]}], "must have shape"),
        ([{"frame": "tool0", "mass": 1.0, "inertia": np.eye(2)}], r"inertia must have shape"),
        ([{"frame": "tool0"}], r"payloads\[0\] needs 'frame' and 'mass'"),
        ([{"frame": "tool0", "mass": 1.0, "color": "red"}], "nothing else"),
        ([3.0], r"payloads\[0\] must be a Payload or a mapping"),
    ],
)
def test_bad_payloads_are_refused_before_sending(payloads: Any, match: str) -> None:
    mock = Recorder()
    with mock.client() as client, pytest.raises(robodyn.InputError, match=match):
        client.mass_matrix("r", [0.0], payloads=payloads)
    assert mock.bodies == []
