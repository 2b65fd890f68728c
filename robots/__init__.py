"""The robodyn robot catalog: data, not code.

`catalog.toml` lists every catalog robot (source file, root joint, SRDF, reference posture);
`textbook/` holds robots bundled with robodyn whose dynamics have a hand-derived closed form.
The loading code lives in `service.registry.catalog`.
"""

from pathlib import Path

CATALOG_DIR = Path(__file__).resolve().parent
CATALOG_FILE = CATALOG_DIR / "catalog.toml"

__all__ = ["CATALOG_DIR", "CATALOG_FILE"]
