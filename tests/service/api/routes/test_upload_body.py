"""An upload's body: a large one is decoded and validated in a child process
(`service.api.upload_body`), and answered exactly as the same body read in the serving process."""

from __future__ import annotations

import os
import signal

import orjson
import pytest
from fastapi.testclient import TestClient

from service.api import upload_body
from service.api.routes import robots as robot_routes
from service.errors import Overloaded
from service.main import create_app
from service.registry import Registry
from service.registry.build_slots import BuildSlots
from service.settings import Settings
from tests.helpers import planar_arm_urdf
from tests.service.processes.from_outside import raised_when_its_child

URDF = planar_arm_urdf(0.9, 0.6, 1.2, 0.8)
JSON = "application/json"
BODIES = {
    "valid": (orjson.dumps({"urdf": URDF}), JSON),
    "not-json": (b'{"urdf": "<robot', JSON),
    "empty": (b"", JSON),
    "labelled-as-text": (b'{"urdf": "<robot/>"}', "text/plain"),
    "labelled-as-problem-json": (b'{"urdf": 1}', "application/problem+json"),
    "nested-too-deeply": (b"[" * 100_000 + b"]" * 100_000, JSON),
    "not-utf-8": (b'{"urdf": "\xff"}', JSON),
    "nan-gravity": (b'{"urdf": "<robot name=\'r\'/>", "gravity": [NaN, 0, 0]}', JSON),
    "misspelt-member": (b'{"urdf": "<robot name=\'r\'/>", "gravty": [0, 0, -9.81]}', JSON),
    "two-descriptions": (b'{"urdf": "<robot/>", "mjcf": "<mujoco/>"}', JSON),
    "many-unknown-members": (
        b'{"urdf": "<robot/>", ' + b", ".join(b'"m%d": 1' % i for i in range(300)) + b"}",
        JSON,
    ),
    "many-wrong-assets": (
        b'{"urdf": "<robot/>", "assets": {'
        + b", ".join(b'"a%d": %d' % (i, i) for i in range(500))
        + b"}}",
        JSON,
    ),
}


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory):
    data_dir = tmp_path_factory.mktemp("upload-body")
    registry = Registry(data_dir, ["planar_arm"])
    registry.load()
    with TestClient(
        create_app(Settings(data_dir=data_dir), registry=registry), raise_server_exceptions=False
    ) as client:
        yield client


@pytest.mark.parametrize("name", BODIES)
def test_a_body_read_in_a_child_is_answered_as_one_read_inline(client, monkeypatch, name):
    body, content_type = BODIES[name]
    inline = client.post("/v1/robots", content=body, headers={"content-type": content_type})
    children: list[int] = []

    def isolated(body: bytes, *args, **kwargs):
        children.append(len(body))
        return upload_body.read_upload_isolated(body, *args, **kwargs)

    monkeypatch.setattr(robot_routes, "INLINE_UPLOAD_BYTES", -1)  # every body is "large"
    monkeypatch.setattr(robot_routes, "read_upload_isolated", isolated)
    isolated_answer = client.post(
        "/v1/robots", content=body, headers={"content-type": content_type}
    )
    assert children == [len(body)]
    assert inline.status_code < 500 and inline.status_code != 400, inline.text[:300]
    if name == "valid":  # stored by the first, found by the second
        assert (inline.status_code, isolated_answer.status_code) in ((201, 200), (200, 200))
    else:
        assert isolated_answer.status_code == inline.status_code, isolated_answer.text[:300]
        assert inline.status_code in (415, 422)
    assert isolated_answer.json() == inline.json()


def test_large_bodies_are_read_in_a_child_small_ones_inline(client, monkeypatch):
    children: list[int] = []

    def isolated(body: bytes, *args, **kwargs):
        children.append(len(body))
        return upload_body.read_upload_isolated(body, *args, **kwargs)

    monkeypatch.setattr(robot_routes, "read_upload_isolated", isolated)
    padding = "x" * upload_body.INLINE_UPLOAD_BYTES
    small = client.post("/v1/robots", json={"urdf": "<robot/>", "name": padding[:1000]})
    large = client.post("/v1/robots", json={"urdf": "<robot/>", "name": padding})
    assert small.status_code == large.status_code == 422
    assert (
        small.json()["errors"]
        == large.json()["errors"]
        == [{"loc": "name", "msg": "must have at most 200 characters"}]
    )
    assert len(children) == 1 and children[0] > upload_body.INLINE_UPLOAD_BYTES


def test_a_body_waiting_for_a_busy_builder_is_refused_as_overloaded():
    slots = BuildSlots(1, wait_s=0.05)
    with slots.slot(), pytest.raises(Overloaded):
        upload_body.read_upload_isolated(b"{}", JSON, slots, timeout_s=5, cpu_s=5)


def test_a_reader_killed_from_outside_is_overloaded():
    """The process reading a large body killed by SIGKILL from outside (the OOM killer): the
    machine's condition, a 503, not a 422 about the body."""
    members = b", ".join(b'"m%d": 1' % i for i in range(2_000_000))  # seconds to read
    body = b'{"urdf": "<robot/>", ' + members + b"}"
    raised = raised_when_its_child(
        lambda: upload_body.read_upload_isolated(
            body, JSON, BuildSlots(1, wait_s=5), timeout_s=120, cpu_s=60
        ),
        lambda pid: os.kill(pid, signal.SIGKILL),
    )
    assert isinstance(raised, Overloaded), raised
    assert "killed by signal 9 (SIGKILL)" in raised.detail
