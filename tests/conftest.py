"""Fixtures: the whole catalog loaded once, and an app over it with a temporary store."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from service.main import create_app
from service.registry import Registry
from service.settings import Settings


@pytest.fixture(scope="session")
def catalog_registry(tmp_path_factory: pytest.TempPathFactory) -> Registry:
    registry = Registry(tmp_path_factory.mktemp("store"))
    registry.load()
    return registry


@pytest.fixture(scope="session")
def api(catalog_registry: Registry) -> Iterator[TestClient]:
    """An HTTP client over the app with the full catalog (uploads go to a session store)."""
    app = create_app(
        Settings(data_dir=catalog_registry.store.dir.parent), registry=catalog_registry
    )
    with TestClient(app, raise_server_exceptions=False) as client:
        yield client


@pytest.fixture
def small_app_factory(tmp_path: Path):
    """Build (settings, registry, TestClient) over a small catalog and a fresh store."""
    clients: list[TestClient] = []

    def build(
        data_dir: Path | None = None, catalog: str = "ur5,planar_arm,talos", **settings_kw
    ) -> TestClient:
        settings = Settings(data_dir=data_dir or tmp_path, catalog=catalog, **settings_kw)
        registry = Registry(settings.data_dir, settings.catalog_names(), settings.build_timeout_s)
        registry.load()
        client = TestClient(create_app(settings, registry=registry), raise_server_exceptions=False)
        clients.append(client)
        return client

    yield build
    for client in clients:
        client.close()
