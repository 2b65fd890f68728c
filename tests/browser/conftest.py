"""Fixtures of the browser tests: a real `python -m service` on a free loopback port, and
Debian's Chromium (never a downloaded browser) driven by Playwright.

The tests skip, saying why, only when the Chromium executable is absent; `.ci/run` installs it
(`apt-get install -y chromium`). Screenshots go to `tests/browser/artifacts/` (git-ignored).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import urlsplit

import httpx
import pytest

from tests.servers import running_server

CHROMIUM = os.environ.get("ROBODYN_TEST_CHROMIUM", "/usr/bin/chromium")
# Flags known to work here as root on a machine without internet (see the environment notes):
# no sandbox (root), WebGL on the CPU (SwiftShader through ANGLE, for the explorer's 3-D view;
# no GPU is used), and none of Chromium's own background connections.
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
CATALOG = "ur5,panda,planar_arm,solo12,double_pendulum_continuous,talos"
ARTIFACTS = Path(__file__).parent / "artifacts"


@pytest.fixture(scope="session")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The service in a subprocess over a small catalog and an empty store: yields its URL."""
    with running_server(tmp_path_factory.mktemp("browser-data"), catalog=CATALOG) as url:
        yield url


@pytest.fixture(scope="session")
def api(server: str) -> Iterator[httpx.Client]:
    """A plain HTTP client of the same server: the reference the page is compared with."""
    with httpx.Client(base_url=server, timeout=30) as client:
        yield client


@pytest.fixture(scope="module")
def browser() -> Iterator[object]:
    """Chromium for one test module. Not for the session: Playwright's sync API keeps an
    asyncio loop marked running in this thread while it is open, which would break the
    asyncio tests of other modules; closing it after each module releases the loop."""
    if not (Path(CHROMIUM).is_file() and os.access(CHROMIUM, os.X_OK)):
        pytest.skip(
            f"browser tests need Debian's Chromium at {CHROMIUM}, which is absent: "
            "run `apt-get install -y chromium` (as .ci/run does); no browser is "
            "downloaded"
        )
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        # Playwright starts the browser on a fresh temporary profile (--user-data-dir) itself.
        chromium = pw.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        try:
            yield chromium
        finally:
            chromium.close()


@dataclass
class PageLog:
    """What a page did: console errors, uncaught exceptions, and every request URL."""

    console_errors: list[str] = field(default_factory=list)
    page_errors: list[str] = field(default_factory=list)
    requests: list[str] = field(default_factory=list)
    failed: list[str] = field(default_factory=list)

    def foreign_requests(self, origin: str) -> list[str]:
        """Requests that went anywhere but `origin` (scheme, host and port)."""
        want = urlsplit(origin)
        return [
            u
            for u in self.requests
            if (urlsplit(u).scheme, urlsplit(u).netloc) != (want.scheme, want.netloc)
        ]


@pytest.fixture
def page(browser, request: pytest.FixtureRequest) -> Iterator[object]:
    """A fresh browser context and page, recording console errors and requests into
    `page.log`, and a screenshot `artifacts/<test name>.png` of its last state."""
    context = browser.new_context(viewport={"width": 1400, "height": 1000})
    context.set_default_timeout(15_000)
    pg = context.new_page()
    log = PageLog()
    pg.on("console", lambda m: log.console_errors.append(m.text) if m.type == "error" else None)
    pg.on("pageerror", lambda e: log.page_errors.append(str(e)))
    pg.on("request", lambda r: log.requests.append(r.url))
    pg.on("requestfailed", lambda r: log.failed.append(f"{r.url}: {r.failure}"))
    pg.log = log  # type: ignore[attr-defined]
    try:
        yield pg
    finally:
        ARTIFACTS.mkdir(exist_ok=True)
        try:
            pg.screenshot(path=str(ARTIFACTS / f"{request.node.name}.png"), full_page=True)
        finally:
            context.close()
