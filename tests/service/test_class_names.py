"""Class names of the service: each defined once in `service/`, so that a name says one thing
(and a pydantic model's name, its OpenAPI component name, is never shadowed)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_each_class_of_the_service_is_defined_once() -> None:
    defined: dict[str, str] = {}
    for path in sorted((ROOT / "service").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef):
                where = str(path.relative_to(ROOT))
                assert node.name not in defined, (node.name, defined.get(node.name), where)
                defined[node.name] = where
