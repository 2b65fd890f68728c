"""`/docs` in a real browser: Swagger UI renders every operation of `/openapi.json` with no
request leaving the service (its assets come from the swagger-ui-bundle-v2 package)."""

from __future__ import annotations

import time
from urllib.parse import urlsplit

from tests.browser.conftest import ARTIFACTS

METHODS = {"get", "put", "post", "delete", "patch", "head", "options", "trace"}


def test_docs_render_every_operation_offline(page, server, api) -> None:
    spec = api.get("/openapi.json").json()
    operations = sorted(
        (method.upper(), path)
        for path, item in spec["paths"].items()
        for method in item
        if method in METHODS
    )
    assert len(operations) >= 10
    page.goto(server + "/docs")
    page.locator(".opblock").first.wait_for()
    page.wait_for_function(
        "(n) => document.querySelectorAll('.opblock').length >= n", arg=len(operations)
    )
    shown = sorted(
        page.eval_on_selector_all(
            ".opblock",
            """bs => bs.map(b => [
            b.querySelector('.opblock-summary-method').textContent.trim(),
            b.querySelector('.opblock-summary-path').dataset.path])""",
        )
    )
    assert shown == [list(op) for op in operations]
    assert "robodyn" in page.locator(".information-container .title").inner_text()
    page.screenshot(path=str(ARTIFACTS / "docs.png"))

    origin_only = page.log.foreign_requests(server)
    assert origin_only == [], f"requests left the service: {origin_only}"
    assert f"{server}/docs/assets/swagger-ui-bundle.js" in page.log.requests
    assert f"{server}/docs/assets/favicon-32x32.png" in page.log.requests
    assert f"{server}/openapi.json" in page.log.requests
    assert page.log.console_errors == [] and page.log.page_errors == []
    assert page.log.failed == []


def test_docs_try_it_out_calls_this_service(page, server, api) -> None:
    """ "Try it out" on GET /v1/robots sends the request to this service and shows its answer."""
    page.goto(server + "/docs")
    block = page.locator(".opblock-get").filter(
        has=page.locator(".opblock-summary-path[data-path='/v1/robots']")
    )
    block.locator(".opblock-summary").click()
    block.locator("button.try-out__btn").click()
    block.locator("button.execute").click()
    body = block.locator(".responses-wrapper .response-col_description .microlight").first
    body.wait_for()
    ids = {r["id"] for r in api.get("/v1/robots").json()["robots"]}
    # Swagger UI may show the answer before it has highlighted all of it: read until complete.
    deadline = time.monotonic() + 10.0
    while True:
        missing = [i for i in ids if f'"{i}"' not in body.inner_text()]
        if not missing or time.monotonic() > deadline:
            break
        page.wait_for_timeout(100)
    assert missing == []
    # GET /v1/robots with the query Swagger UI fills in (the page's `limit`)
    assert any(urlsplit(u).path == "/v1/robots" for u in page.log.requests), page.log.requests
    assert page.log.foreign_requests(server) == []
