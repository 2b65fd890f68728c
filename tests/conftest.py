"""Fixtures: the whole catalog loaded once, an app over it with a temporary store, and the
check that the session leaves no process behind."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from service import processes
from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.descendants import wait_no_descendants

LEFTOVER_WAIT_S = 10.0  # for children killed at the very end to be reaped


@pytest.fixture(scope="session", autouse=True)
def no_process_left_behind() -> Iterator[None]:
    """Set up first, so torn down last, after every other fixture. Then no child started by
    `service.processes` may still be tracked (each fixture and app lifespan stops its own);
    the process-wide ones, started by whichever test needed them first (the forkserver, the
    JSON helper, multiprocessing's resource tracker), are stopped by `processes.shutdown()`;
    and pytest must have no child process left at all (servers, browsers, helpers)."""
    yield
    tracked = {proc.pid: proc.name for proc in processes.live_children()}
    processes.shutdown()
    left = wait_no_descendants(os.getpid(), LEFTOVER_WAIT_S)
    problems = []
    if tracked:
        problems.append(f"children of service.processes still running: {tracked}")
    if left:
        listed = "; ".join(f"{pid}: {cmd[:160]}" for pid, cmd in sorted(left.items()))
        problems.append(f"processes left behind by the test session: {listed}")
    if problems:
        pytest.fail("\n".join(problems), pytrace=False)


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
