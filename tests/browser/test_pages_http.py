"""The pages' HTTP side, without a browser: what `/` and `/docs` reference is served by the
service itself, from the package that ships it, and nothing else is reachable."""

from __future__ import annotations

import re
from html.parser import HTMLParser
from pathlib import Path

import pytest
from swagger_ui_bundle import swagger_ui_path

from service.api.routes.pages import DOCS_FILES, EXPLORER_FILES, MODULE_FILES, WEB_DIR


class _Refs(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.refs: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.refs += [v for k, v in attrs if k in ("src", "href") and v]


def _refs(html: str) -> list[str]:
    parser = _Refs()
    parser.feed(html)
    return parser.refs


@pytest.fixture
def client(small_app_factory):
    return small_app_factory(catalog="planar_arm")


def test_explorer_page_references_only_its_own_files(client) -> None:
    page = client.get("/")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    assert "default-src 'self'" in page.headers["content-security-policy"]
    refs = _refs(page.text)
    assert set(refs) == {"docs", *(f"static/{name}" for name in EXPLORER_FILES)}
    for name, media_type in EXPLORER_FILES.items():
        answer = client.get(f"/static/{name}")
        assert answer.status_code == 200, name
        assert answer.headers["content-type"] == media_type
        assert answer.content == (WEB_DIR / name).read_bytes()


def test_explorer_modules_are_served_and_the_import_map_is_the_only_inline_script(client) -> None:
    """The explorer's modules and the vendored three.js modules (with their licence in the
    repository) are served as JavaScript; the CSP admits exactly the inline import map, by its
    hash."""
    import base64
    import hashlib

    for name, media_type in MODULE_FILES.items():
        answer = client.get(f"/static/{name}")
        assert answer.status_code == 200, name
        assert answer.headers["content-type"] == media_type
        assert answer.content == (WEB_DIR / name).read_bytes()
    assert "MIT License" in (WEB_DIR / "vendor/three/LICENSE").read_text()
    assert "three@0.170.0" in (WEB_DIR / "vendor/three/README.md").read_text()
    page = client.get("/")
    scripts = re.findall(r"<script([^>]*)>(.*?)</script>", page.text, flags=re.DOTALL)
    inline = [body for attrs, body in scripts if body.strip()]
    assert len(inline) == 1 and 'type="importmap"' in scripts[0][0]
    digest = base64.b64encode(hashlib.sha256(inline[0].encode()).digest()).decode()
    csp = page.headers["content-security-policy"]
    script_src = next(d for d in csp.split(";") if d.strip().startswith("script-src"))
    assert script_src.split() == ["script-src", "'self'", f"'sha256-{digest}'"]
    assert "unsafe" not in csp
    # every specifier of the import map is a file that is served
    for target in re.findall(r'"\./(static/[^"]+)"', inline[0]):
        if target.endswith("/"):
            assert any(f"static/{n}".startswith(target) for n in MODULE_FILES), target
        else:
            assert client.get("/" + target).status_code == 200, target


def test_explorer_files_name_no_other_origin() -> None:
    # (the vendored three.js files name example URLs in comments; the browser tests check
    # that no request leaves the service)
    own_modules = [n for n in MODULE_FILES if not n.startswith("vendor/")]
    for name in ["index.html", *EXPLORER_FILES, *own_modules]:
        text = (WEB_DIR / name).read_text()
        urls = set(re.findall(r"[a-z][a-z0-9+.-]*://[^\s\"'`)]+", text))
        assert urls <= {"http://www.w3.org/2000/svg"}, (name, urls)  # an XML namespace name
        assert "//" not in "".join(re.findall(r"(?:src|href)=\"([^\"]*)\"", text))


def test_docs_page_loads_swagger_ui_from_the_installed_package(client) -> None:
    page = client.get("/docs")
    assert page.status_code == 200
    assert "'self'" in page.headers["content-security-policy"]
    refs = _refs(page.text)
    assert sorted(refs) == sorted(f"/docs/assets/{name}" for name in DOCS_FILES)
    assert "url: '/openapi.json'" in page.text
    assert '"validatorUrl": null' in page.text  # no badge from validator.swagger.io
    assert not re.search(r"https?://", page.text)
    for name, media_type in DOCS_FILES.items():
        answer = client.get(f"/docs/assets/{name}")
        assert answer.status_code == 200, name
        assert answer.headers["content-type"] == media_type
        assert answer.content == (Path(str(swagger_ui_path)) / name).read_bytes()
    assert b"SwaggerUIBundle" in client.get("/docs/assets/swagger-ui-bundle.js").content


@pytest.mark.parametrize(
    "path",
    [
        "/static/__init__.py",
        "/static/index.html",
        "/static/..%2f..%2fmain.py",
        "/static/../api/routes/pages.py",
        "/static/vendor/three/package.json",
        "/static/vendor/three/README.md",
        "/static/vendor%2F..%2Fpages.py",
        "/static/vendor/three/build/../../../__init__.py",
        "/docs/assets/index.html",
        "/docs/assets/swagger-initializer.js",
        "/docs/assets/..%2f..%2f__init__.py",
        "/redoc",
        "/docs/oauth2-redirect",
    ],
)
def test_nothing_else_is_served(client, path: str) -> None:
    answer = client.get(path)
    assert answer.status_code == 404
    assert answer.headers["content-type"] == "application/problem+json"
    assert answer.json()["code"] == "not_found"


def test_pages_are_not_api_operations(client) -> None:
    paths = client.get("/openapi.json").json()["paths"]
    assert not [p for p in paths if not p.startswith(("/v1/", "/health/", "/metrics"))]


def test_every_served_page_file_is_in_the_tree() -> None:
    """Each file the page routes may serve exists (a file missing from the tree, e.g. one a
    .gitignore rule kept out of the repository, would answer 500 instead of the file)."""
    from service.api.routes import pages

    missing = [name for name in pages.STATIC_FILES if not (pages.WEB_DIR / name).is_file()]
    assert missing == []
