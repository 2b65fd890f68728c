"""Fixtures of the client tests: the real app in process, a real server in a subprocess, and
in-process Pinocchio as the reference that answers are compared with."""

from __future__ import annotations

from collections.abc import AsyncIterator, Iterator
from typing import Any

import httpx
import pytest
from fastapi.testclient import TestClient
from robodyn import AsyncClient, Client

from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.client.helpers import API_KEY, CATALOG, Reference, running_server


@pytest.fixture(scope="session")
def registry(tmp_path_factory: pytest.TempPathFactory) -> Registry:
    r = Registry(tmp_path_factory.mktemp("client-data"), CATALOG)
    r.load()
    assert not r.catalog_failures, r.catalog_failures
    return r


@pytest.fixture(scope="session")
def app(registry: Registry, tmp_path_factory: pytest.TempPathFactory) -> Any:
    return create_app(Settings(data_dir=tmp_path_factory.mktemp("unused")), registry=registry)


@pytest.fixture(scope="session")
def reference(registry: Registry) -> Reference:
    return Reference(registry)


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A real server (once per module) serving CATALOG; uploads need API_KEY. Its URL."""
    with running_server(
        tmp_path_factory.mktemp("server-data"), catalog=",".join(CATALOG), api_keys=API_KEY
    ) as url:
        yield url


@pytest.fixture(autouse=True)
def _no_retries() -> Iterator[None]:
    """Errors at once in the client tests (stamina's test mode: one attempt, no waits); the
    retry tests (test_client_ecosystem.py) turn real retries back on."""
    import stamina

    with stamina.set_testing(True, attempts=1):
        yield


@pytest.fixture(scope="module")
def client(app: Any) -> Iterator[Client]:
    """A `Client` on the real app in process (module scope: its connection pool is reused)."""
    with TestClient(app, raise_server_exceptions=False) as http, Client(http_client=http) as c:
        yield c


@pytest.fixture
def anyio_backend() -> str:
    return "asyncio"


@pytest.fixture
async def aclient(app: Any) -> AsyncIterator[AsyncClient]:
    """An `AsyncClient` on the real app in process, through httpx's ASGI transport."""
    transport = httpx.ASGITransport(app=app)
    async with (
        httpx.AsyncClient(transport=transport, base_url="http://robodyn.test") as http,
        AsyncClient(http_client=http) as c,
    ):
        yield c
