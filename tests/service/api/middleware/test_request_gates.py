"""What is decided before a request's body is read or its robot computed with: HEAD on every
GET route, the API key before the body, and a robot deleted under an open stream."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.helpers import planar_arm_urdf


def _client(tmp_path: Path, **settings_kw: object) -> TestClient:
    settings = Settings(data_dir=tmp_path, catalog="planar_arm", **settings_kw)  # type: ignore[arg-type]
    registry = Registry(settings.data_dir, settings.catalog_names(), settings.build_timeout_s)
    registry.load()
    return TestClient(create_app(settings, registry=registry), raise_server_exceptions=False)


@pytest.mark.parametrize(
    "path",
    [
        "/health/live",
        "/health/ready",
        "/v1/robots",
        "/v1/robots/planar_arm",
        "/v1/robots/planar_arm/inertias",
        "/v1/robots/planar_arm/visuals",
        "/",
        "/openapi.json",
    ],
)
def test_head_is_get_without_the_body(tmp_path, path):
    with _client(tmp_path) as client:
        got, head = client.get(path), client.head(path)
    assert got.status_code == head.status_code == 200, (got.status_code, head.status_code)
    assert head.content == b""
    assert head.headers["content-type"] == got.headers["content-type"]
    assert head.headers["content-length"] == str(len(got.content))


def test_head_on_a_post_route_is_still_405(tmp_path):
    with _client(tmp_path) as client:
        head = client.head("/v1/robots/planar_arm/gravity")
        assert (head.status_code, head.content) == (405, b"")  # a HEAD answer has no body
        assert head.headers["content-type"] == "application/problem+json"
        assert client.head("/v1/robots/nope").status_code == 404


async def _asgi_post(
    app, path: str, body: bytes, headers: list[tuple[bytes, bytes]]
) -> tuple[int, bool]:
    """POST `body` through the ASGI app; (status, whether the app read the body)."""
    read = False
    sent: list[dict] = []

    async def receive() -> dict:
        nonlocal read
        read = True
        return {"type": "http.request", "body": body, "more_body": False}

    async def send(message: dict) -> None:
        sent.append(message)

    scope = {
        "type": "http",
        "asgi": {"version": "3.0"},
        "http_version": "1.1",
        "method": "POST",
        "scheme": "http",
        "path": path,
        "raw_path": path.encode(),
        "query_string": b"",
        "root_path": "",
        "server": ("test", 80),
        "client": ("127.0.0.1", 1),
        "headers": [
            (b"content-type", b"application/json"),
            (b"content-length", str(len(body)).encode()),
            *headers,
        ],
    }
    await app(scope, receive, send)
    return sent[0]["status"], read


@pytest.mark.parametrize(
    ("scope", "path"),
    [
        ("all", "/v1/robots/planar_arm/gravity"),
        ("all", "/v1/robots/planar_arm/reduce"),
        ("writes", "/v1/robots"),
        ("writes", "/v1/robots/planar_arm/reduce"),
        ("writes", "/v1/robots/planar_arm/variants"),
    ],
)
def test_a_request_without_its_key_is_refused_before_its_body_is_read(tmp_path, scope, path):
    """Before: the body was read and parsed (seconds for a large one) just to answer 401."""
    with _client(tmp_path, api_keys="k1", api_keys_scope=scope) as client:
        body = json.dumps({"q": [0.0, 0.0]}).encode()
        status, read = asyncio.run(_asgi_post(client.app, path, body, []))
        assert (status, read) == (401, False)
        status, read = asyncio.run(
            _asgi_post(client.app, path, body, [(b"authorization", b"Bearer k1")])
        )
        assert status != 401 and read


def test_a_stream_answers_404_once_its_robot_is_deleted(tmp_path):
    with _client(tmp_path) as client:
        upload = client.post("/v1/robots", json={"urdf": planar_arm_urdf(0.7, 0.5, 1.5, 0.5)})
        assert upload.status_code == 201, upload.text
        robot = upload.json()["id"]
        with client.websocket_connect(f"/v1/robots/{robot}/stream") as ws:
            ws.send_text(json.dumps({"quantity": "gravity", "q": [0.1, 0.2]}))
            assert "gravity" in json.loads(ws.receive_text())
            assert client.delete(f"/v1/robots/{robot}").status_code == 204
            ws.send_text(json.dumps({"quantity": "gravity", "q": [0.1, 0.2]}))
            problem = json.loads(ws.receive_text())
            assert problem["code"] == "robot_not_found" and problem["status"] == 404
