"""The explorer's requests (http.js) on a server whose every /v1 route needs an API key
(ROBODYN_API_KEYS_SCOPE=all): without a key the page says it needs one; with the key entered,
every request it sends to /v1 — the robot list, the robot, its dynamics, its visuals and mesh
files, the payload view's, a trajectory check's progress stream — carries it, and none is
refused."""

from __future__ import annotations

from collections.abc import Iterator
from urllib.parse import urlsplit

import httpx
import pytest

from tests.browser.test_explorer import wait_computed
from tests.browser.test_payload_view import wait_payload
from tests.browser.test_trajectory_view import CSV
from tests.servers import running_server

KEY = "explorer-browser-test-key"


@pytest.fixture(scope="module")
def keyed_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The service with one API key, needed for every /v1 route: yields its URL."""
    with running_server(
        tmp_path_factory.mktemp("keyed-data"),
        catalog="ur5,planar_arm",
        api_keys=KEY,
        api_keys_scope="all",
    ) as url:
        yield url


def _v1(url: str) -> str | None:
    path = urlsplit(url).path
    return path if path.startswith("/v1/") else None


def test_every_request_carries_the_key_the_user_entered(page, keyed_server) -> None:
    sent: list[tuple[str, str | None]] = []  # (path, Authorization) of each /v1 request, in order
    answered: list[tuple[str, str | None, int]] = []  # (path, Authorization, status)
    page.on(
        "request",
        lambda r: sent.append((_v1(r.url), r.headers.get("authorization"))) if _v1(r.url) else None,
    )
    page.on(
        "response",
        lambda r: (
            answered.append((_v1(r.url), r.request.headers.get("authorization"), r.status))
            if _v1(r.url)
            else None
        ),
    )
    # the server's contract: reads need the key
    assert httpx.get(keyed_server + "/v1/robots").status_code == 401
    keyed = {"Authorization": f"Bearer {KEY}"}
    assert httpx.get(keyed_server + "/v1/robots", headers=keyed).is_success

    page.goto(keyed_server + "/")
    page.wait_for_function(
        "() => document.querySelector('#status').textContent.includes('needs an API key')"
    )
    assert "error" in (page.locator("#status").get_attribute("class") or "")
    assert sent and all(auth is None for _, auth in sent)  # no key entered: none sent

    page.fill("#api-key", KEY)
    page.press("#api-key", "Enter")
    wait_computed(page)
    assert page.locator("#robot").input_value() == "ur5"
    page.wait_for_function("""() => {
        const p = document.querySelector('#view-progress');
        return +p.dataset.total > 0 && p.dataset.done === p.dataset.total }""")
    assert page.locator("#view-progress").get_attribute("data-failed") == "0"  # every mesh
    page.click("#payload-view-button")
    wait_payload(page)
    page.click("#tab-trajectory-button")
    page.fill("#trajectory-csv", CSV)
    page.click("#trajectory-check")
    page.locator("#trajectory-verdict").wait_for()

    first = next(k for k, (_, auth) in enumerate(sent) if auth is not None)
    with_key = sent[first:]
    assert [(path, auth) for path, auth in with_key if auth != f"Bearer {KEY}"] == []
    paths = {path for path, _ in with_key}
    for wanted in (
        "/v1/robots",
        "/v1/robots/ur5",
        "/v1/robots/ur5/mass-matrix",
        "/v1/robots/ur5/visuals",
        "/v1/robots/ur5/payload-capacity",
        "/v1/robots/ur5/trajectory-check",
    ):
        assert wanted in paths, wanted
    assert any(path.startswith("/v1/robots/ur5/assets/") for path in paths)  # mesh files
    # refused exactly while no key was sent, answered once it was
    assert [(p, a, s) for p, a, s in answered if (s == 401) != (a is None)] == []
    assert [(p, s) for p, a, s in answered if a is not None and s >= 400] == []
    assert page.log.page_errors == []
