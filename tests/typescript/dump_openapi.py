"""Write the service's OpenAPI document (the one GET /openapi.json serves) to a file, from the
app in process: `python tests/typescript/dump_openapi.py OUT.json`."""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

from service.main import create_app
from service.registry import Registry
from service.settings import Settings


def openapi_document() -> dict[str, object]:
    """The document of an app over an empty registry (the document does not depend on it)."""
    with tempfile.TemporaryDirectory() as data:
        settings = Settings(data_dir=Path(data), catalog="ur5")
        app = create_app(settings, registry=Registry(settings.data_dir, []))
        return app.openapi()


if __name__ == "__main__":
    Path(sys.argv[1]).write_text(json.dumps(openapi_document(), indent=1))
