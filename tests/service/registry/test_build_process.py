"""A builder killed by SIGKILL from outside (the kernel's OOM killer) during a build is the
machine's condition: 503 overloaded with Retry-After naming the signal, never a 422 saying the
model is invalid (a builder past its own limits stays a 422:
`tests/hardening/test_corpus_server.py`, and `killed_from_outside` in
`tests/service/processes/test_children.py`)."""

from __future__ import annotations

import os
import signal

from fastapi.testclient import TestClient

from service.errors import Overloaded
from service.main import create_app
from service.registry import Registry
from service.registry.build_process import build_upload
from service.settings import Settings
from tests.hardening.corpus import chain
from tests.service.processes.from_outside import raised_when_its_child

LARGE = chain(128, flat=True)  # about a second of building and checking


def test_a_builder_killed_from_outside_is_overloaded():
    raised = raised_when_its_child(
        lambda: build_upload(LARGE, "fixed", None, 120.0, max_nv=128),
        lambda pid: os.kill(pid, signal.SIGKILL),
    )
    assert isinstance(raised, Overloaded), raised
    assert "killed by signal 9 (SIGKILL)" in raised.detail and "out of memory" in raised.detail


def test_an_upload_whose_builder_is_killed_is_a_503_with_retry_after(tmp_path):
    registry = Registry(tmp_path, ["planar_arm"])
    registry.load()
    app = create_app(Settings(data_dir=tmp_path, catalog="planar_arm"), registry=registry)
    with TestClient(app, raise_server_exceptions=False) as client:
        answers: list = []

        def upload() -> None:
            answers.append(client.post("/v1/robots", json={"urdf": LARGE}))
            raise RuntimeError("answered")

        raised_when_its_child(upload, lambda pid: os.kill(pid, signal.SIGKILL))
    (answer,) = answers
    assert answer.status_code == 503, answer.text
    assert answer.headers["retry-after"] and answer.json()["code"] == "overloaded"
    assert "killed by signal 9" in answer.json()["detail"]
