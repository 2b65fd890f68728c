"""API keys over every route of the app (the route list comes from the app itself): which routes
need a key in each scope, the 401 answer, and that keys never reach the logs."""

from __future__ import annotations

import logging
import re

import pytest

KEY = "s3cr3t-key-0123456789"


def classify(path: str, method: str, tags: list[str]) -> str:
    """The policy: `open` outside /v1; `compute` for the dynamics operations; `write` for any
    other operation that is not a read (it changes the set of models); `read` otherwise."""
    if not path.startswith("/v1"):
        return "open"
    if "dynamics" in tags:
        return "compute"
    return "read" if method == "GET" else "write"


def http_routes(app) -> list[tuple[str, str, str]]:
    """Every HTTP operation of the app: those of its OpenAPI document (generated from the app's
    routes) and the framework's own routes (docs, the document itself)."""
    out = []
    for path, operations in app.openapi()["paths"].items():
        for method, operation in operations.items():
            concrete = re.sub(r"\{[^}]+\}", "ur5", path)
            out.append(
                (
                    method.upper(),
                    concrete,
                    classify(path, method.upper(), operation.get("tags", [])),
                )
            )
    for route in app.routes:
        path = getattr(route, "path", None)
        if path is not None and path not in app.openapi()["paths"]:
            for method in sorted(getattr(route, "methods", None) or ()):
                if method != "HEAD":
                    out.append((method, path, classify(path, method, [])))
    return out


def call(client, method: str, path: str, key: str | None):
    headers = {"Authorization": f"Bearer {key}"} if key else {}
    if method in ("POST", "PUT", "PATCH"):
        return client.request(method, path, json={}, headers=headers)
    return client.request(method, path, headers=headers)


NEEDS_KEY = {"writes": {"write"}, "all": {"write", "read", "compute"}}


@pytest.mark.parametrize("scope", ["writes", "all"])
def test_every_route_follows_the_key_policy(app_factory, scope, caplog):
    client = app_factory(api_keys=f"other-key, {KEY}", api_keys_scope=scope)
    routes = http_routes(client.app)
    kinds = {kind for _, _, kind in routes}
    assert kinds == {"open", "read", "write", "compute"}, routes  # the policy sees every kind
    assert len([r for r in routes if r[2] == "compute"]) >= 6
    caplog.set_level(logging.DEBUG)
    for method, path, kind in routes:
        for key in (None, "wrong-key", f"{KEY}x", KEY[:-1]):
            r = call(client, method, path, key)
            if kind in NEEDS_KEY[scope]:
                assert r.status_code == 401, (method, path, key, r.text)
                assert r.json()["code"] == "unauthorized"
                assert r.headers["www-authenticate"].startswith("Bearer")
                assert KEY not in r.text
            else:
                assert r.status_code != 401, (method, path, key, r.text)
        r = call(client, method, path, KEY)
        assert r.status_code != 401, (method, path, r.text)
        assert r.status_code < 500, (method, path, r.text)
    # the wrong scheme is refused too, and the key never appears in the logs
    r = client.request("DELETE", "/v1/robots/u-0", headers={"Authorization": f"Basic {KEY}"})
    assert r.status_code == 401
    assert KEY not in caplog.text


def test_without_keys_nothing_needs_one(app_factory):
    client = app_factory()
    for method, path, _ in http_routes(client.app):
        assert call(client, method, path, None).status_code != 401, (method, path)


def test_open_routes_stay_open_in_scope_all(app_factory):
    client = app_factory(api_keys=KEY, api_keys_scope="all")
    for path in ("/health/live", "/health/ready", "/metrics", "/openapi.json", "/docs"):
        assert client.get(path).status_code == 200, path
    assert client.get("/v1/robots").status_code == 401
    ok = client.get("/v1/robots", headers={"Authorization": f"Bearer {KEY}"})
    assert ok.status_code == 200 and "ur5" in {r["id"] for r in ok.json()["robots"]}
