"""The validation floods of `floods.py`, in-process at a moderate size: each is a small 422
naming the first mistakes, and the error objects built are bounded whatever the body's size."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.hardening.conftest import LEAK
from tests.hardening.floods import ANSWER_BYTES, FLOODS, Flood


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory):
    settings = Settings(data_dir=tmp_path_factory.mktemp("floods"), catalog="planar_arm")
    registry = Registry(settings.data_dir, settings.catalog_names(), settings.build_timeout_s)
    registry.load()
    with TestClient(
        create_app(settings, registry=registry), raise_server_exceptions=False
    ) as client:
        yield client


@pytest.mark.parametrize("flood", FLOODS, ids=[f.id for f in FLOODS])
def test_a_flood_is_a_small_422_naming_the_first_mistakes(client, flood: Flood):
    r = client.post(
        flood.path, content=flood.body(flood.small), headers={"content-type": flood.content_type}
    )
    assert r.status_code == 422, r.text[:500]
    problem = r.json()
    assert problem["code"] == "validation_error"
    assert flood.fragment in r.text, problem
    assert len(r.content) < ANSWER_BYTES, (flood.id, len(r.content))
    assert len(problem.get("errors", [])) <= 21
    assert not LEAK.search(r.text)
    assert client.get("/health/live").status_code == 200
