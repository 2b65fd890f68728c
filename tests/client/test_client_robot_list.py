"""The robot list from the client: `robots()` follows the pages to the end, `robot_page()`
gives one page and where the next starts; sync and async alike."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
import robodyn
from fastapi.testclient import TestClient
from robodyn import AsyncClient, Client

from service.main import create_app
from service.registry import Registry
from service.settings import Settings


@pytest.fixture(scope="module")
def app(tmp_path_factory: pytest.TempPathFactory):
    data: Path = tmp_path_factory.mktemp("robot-list")
    registry = Registry(data, ["ur5", "planar_arm"])
    registry.load()
    app = create_app(Settings(data_dir=data), registry=registry)
    with TestClient(app) as http:
        for i in range(1, 8):
            payloads = [{"frame": "link2", "mass": 0.25 * i}]
            r = http.post("/v1/robots/planar_arm/variants", json={"payloads": payloads})
            assert r.status_code == 201, r.text
    return app


@pytest.fixture(scope="module")
def whole(app) -> list[str]:
    """The ids of the whole list, from one raw request of the largest page."""
    with TestClient(app) as http:
        answer = http.get("/v1/robots", params={"limit": 1000}).json()
    assert answer["next_cursor"] is None and len(answer["robots"]) == 9
    return [r["id"] for r in answer["robots"]]


@pytest.fixture(scope="module")
def client(app) -> Iterator[Client]:
    with TestClient(app, raise_server_exceptions=False) as http, Client(http_client=http) as c:
        yield c


def test_robots_follows_every_page(client: Client, whole: list[str]) -> None:
    for page_size in (None, 1, 2, 4, 9, 50):
        listed = client.robots(page_size=page_size)
        assert listed.ids == whole and listed.next_cursor is None, page_size
        assert "ur5" in listed and listed.unavailable == {}


def test_robot_page_is_one_page(client: Client, whole: list[str]) -> None:
    first = client.robot_page(limit=4)
    assert first.ids == whole[:4] and first.next_cursor is not None
    second = client.robot_page(limit=4, cursor=first.next_cursor)
    third = client.robot_page(limit=4, cursor=second.next_cursor)
    assert second.ids + third.ids == whole[4:] and third.next_cursor is None
    with pytest.raises(robodyn.InputError, match="limit"):
        client.robot_page(limit=0)
    with pytest.raises(robodyn.ValidationError, match="limit"):
        client.robot_page(limit=5000)  # over the server's largest page
    with pytest.raises(robodyn.ValidationError, match="cursor"):
        client.robot_page(cursor="made-up")


@pytest.fixture
def anyio_backend() -> str:
    return "asyncio"


@pytest.mark.anyio
async def test_the_async_client_follows_the_pages(app, whole: list[str]) -> None:
    transport = httpx.ASGITransport(app=app)
    async with (
        httpx.AsyncClient(transport=transport, base_url="http://robodyn.test") as http,
        AsyncClient(http_client=http) as client,
    ):
        assert (await client.robots(page_size=2)).ids == whole
        page = await client.robot_page(limit=3)
        assert page.ids == whole[:3] and page.next_cursor is not None
