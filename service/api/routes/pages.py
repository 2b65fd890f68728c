"""Human pages: the explorer at `GET /` and the API documentation at `GET /docs`, both offline.

Neither page loads anything from outside the service. The explorer's files are package data of
`service.web`; Swagger UI's JavaScript, CSS and favicon come from the `swagger-ui-bundle-v2`
distribution (import name `swagger_ui_bundle`, Swagger UI 5, which renders OpenAPI 3.1), served
under `/docs/assets/`. Only the files the pages reference are served (an allow-list), so neither
the Python sources next to them nor Swagger UI's demo `index.html` (which points at a remote
example API) is reachable. A Content-Security-Policy of `'self'` makes the browser itself refuse
any other origin.

The explorer's 3-D view uses three.js, vendored under `service/web/vendor/three/` (version and
origin in its README) and loaded as ES modules through an import map inline in `index.html`;
the policy admits that one inline script by its SHA-256 hash, computed here from the file, and
no other.
"""

from __future__ import annotations

import base64
import hashlib
import re
from importlib.resources import files
from pathlib import Path

from fastapi import APIRouter, HTTPException, Request
from fastapi.openapi.docs import get_swagger_ui_html, swagger_ui_default_parameters
from fastapi.responses import FileResponse, HTMLResponse
from swagger_ui_bundle import swagger_ui_path

router = APIRouter(include_in_schema=False)

WEB_DIR = Path(str(files("service.web")))
SWAGGER_DIR = Path(str(swagger_ui_path))

_JS = "text/javascript; charset=utf-8"
# name → media type of every file the pages may load; anything else is a 404.
EXPLORER_FILES = {
    "explorer.js": _JS,
    "explorer.css": "text/css; charset=utf-8",
    "vendor/uplot/uPlot.min.css": "text/css; charset=utf-8",
    "favicon.svg": "image/svg+xml",
}
# ES modules the explorer imports (not named by index.html itself): its views and what they
# share, the vendored three.js files it uses (each module's own relative imports included) and
# the vendored uPlot (service/web/vendor/uplot/README.md).
THREE_DIR = "vendor/three/"
MODULE_FILES = {
    name: _JS
    for name in [
        "robot_drawing.js",
        "robot_view.js",
        "robot_list_view.js",
        "dynamics_view.js",
        "no_value.js",
        "plot_axes.js",
        "joint_coordinates.js",
        "mass_matrix_view.js",
        "http.js",
        "tabs.js",
        "payload_view.js",
        "model_check_view.js",
        "equations_view.js",
        "trajectory_view.js",
        "joint_sizing.js",
        "vendor/uplot/uPlot.esm.js",
        "identification_view.js",
        THREE_DIR + "build/three.module.min.js",
        THREE_DIR + "examples/jsm/controls/OrbitControls.js",
        THREE_DIR + "examples/jsm/loaders/STLLoader.js",
        THREE_DIR + "examples/jsm/loaders/ColladaLoader.js",
        THREE_DIR + "examples/jsm/loaders/TGALoader.js",
        THREE_DIR + "examples/jsm/loaders/OBJLoader.js",
        THREE_DIR + "examples/jsm/loaders/GLTFLoader.js",
        THREE_DIR + "examples/jsm/utils/BufferGeometryUtils.js",
    ]
}
# KaTeX (vendored, see its README), loaded by the "Equations" view on first use: its script,
# stylesheet and the woff2 fonts the stylesheet names.
KATEX_DIR = "vendor/katex/"
KATEX_FILES = {
    KATEX_DIR + "katex.min.js": _JS,
    KATEX_DIR + "katex.min.css": "text/css; charset=utf-8",
    **{
        KATEX_DIR + "fonts/" + font.name: "font/woff2"
        for font in sorted((WEB_DIR / KATEX_DIR / "fonts").glob("*.woff2"))
    },
}
STATIC_FILES = {**EXPLORER_FILES, **MODULE_FILES, **KATEX_FILES}


def _inline_script_hashes(html: str) -> str:
    """CSP source expressions ('sha256-…') of the inline scripts of a page (its import map)."""
    scripts = re.findall(r"<script[^>]*>(.*?)</script>", html, flags=re.DOTALL)
    return " ".join(
        f"'sha256-{base64.b64encode(hashlib.sha256(body.encode()).digest()).decode()}'"
        for body in scripts
        if body.strip()
    )


DOCS_FILES = {
    "swagger-ui-bundle.js": "text/javascript; charset=utf-8",
    "swagger-ui.css": "text/css; charset=utf-8",
    "favicon-32x32.png": "image/png",
}

# The browser enforces "nothing from elsewhere": scripts, styles, images, fonts and fetches
# only from this origin (images also as data: URIs, which Swagger UI's CSS uses for icons).
# The one inline script is the import map, admitted by its hash.
EXPLORER_CSP = (
    "default-src 'self'; "
    f"script-src 'self' {_inline_script_hashes((WEB_DIR / 'index.html').read_text())}; "
    "img-src 'self' data:; object-src 'none'; "
    "base-uri 'none'; frame-ancestors 'none'; form-action 'none'"
)
# FastAPI's docs page starts Swagger UI with an inline script; Swagger UI sets inline styles.
DOCS_CSP = (
    "default-src 'self'; script-src 'self' 'unsafe-inline'; "
    "style-src 'self' 'unsafe-inline'; img-src 'self' data:; object-src 'none'; "
    "base-uri 'none'; frame-ancestors 'none'"
)
_REVALIDATE = "no-cache"  # files change with the installed version; ETags make it cheap


def _file(directory: Path, name: str, allowed: dict[str, str]) -> FileResponse:
    if name not in allowed:
        raise HTTPException(404)  # answered as problem+json `not_found` by the handlers
    return FileResponse(
        directory / name, media_type=allowed[name], headers={"Cache-Control": _REVALIDATE}
    )


@router.get("/")
async def explorer_page() -> FileResponse:
    """The explorer: choose a robot, move its joints, see M(q), g(q) and C(q, v) v."""
    return FileResponse(
        WEB_DIR / "index.html",
        media_type="text/html; charset=utf-8",
        headers={"Cache-Control": _REVALIDATE, "Content-Security-Policy": EXPLORER_CSP},
    )


@router.get("/static/{name:path}")
async def explorer_file(name: str) -> FileResponse:
    return _file(WEB_DIR, name, STATIC_FILES)


@router.get("/docs")
async def api_docs(request: Request) -> HTMLResponse:
    """Swagger UI over `/openapi.json`, with every asset served by this service."""
    root = request.scope.get("root_path", "")
    openapi_url = request.app.openapi_url or "/openapi.json"
    page = get_swagger_ui_html(
        openapi_url=f"{root}{openapi_url}",
        title=f"{request.app.title} — API documentation",
        swagger_js_url=f"{root}/docs/assets/swagger-ui-bundle.js",
        swagger_css_url=f"{root}/docs/assets/swagger-ui.css",
        swagger_favicon_url=f"{root}/docs/assets/favicon-32x32.png",
        # validatorUrl None: no badge fetched from validator.swagger.io.
        swagger_ui_parameters={**swagger_ui_default_parameters, "validatorUrl": None},
    )
    page.headers["Content-Security-Policy"] = DOCS_CSP
    return page


@router.get("/docs/assets/{name}")
async def api_docs_file(name: str) -> FileResponse:
    return _file(SWAGGER_DIR, name, DOCS_FILES)
