"""A variant's lineage: the root it derives from and the variants between (the flat form of
`service.registry.records`), how a new variant's lineage follows from its parent's record, and
the cap on how deep a lineage goes.

The depth of a model is the number of variants from its root to it, itself included: 0 for a
catalog robot or an uploaded description, 1 for a variant of one, d + 1 for a variant of a
model of depth d. A record holds its whole lineage, so it rebuilds without its ancestors'
records (deleting a parent leaves its variants working), and its size, the time to check it
and the time to rebuild it grow linearly with its depth.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from service.errors import InvalidInput
from service.registry.records import STEP_KEYS, VARIANT_FORMATS
from service.registry.upload_formats import REBUILD_KEYS

MAX_VARIANT_DEPTH = 32
"""The deepest variant that can be stored: a variant of a variant ... 32 times over."""

Lineage = tuple[dict[str, Any], list[dict[str, Any]]]
"""(base, steps): a record's `base` (the root) and `steps` (root first, up to the parent)."""


def depth(record: Mapping[str, Any] | None) -> int:
    """The depth of the model stored as `record` (None: a catalog robot), 0 to any number."""
    if record is None or record.get("format") not in VARIANT_FORMATS:
        return 0
    return len(record["steps"]) + 1


def child_lineage(
    parent_id: str, parent_record: Mapping[str, Any] | None, name: str, warnings: list[Any]
) -> Lineage:
    """The lineage of a new variant of the robot `parent_id` (its stored record, flat; None
    for a catalog robot; `name` and `warnings` are the parent's as served). `InvalidInput`
    (422) if the variant would be deeper than `MAX_VARIANT_DEPTH`."""
    parent_depth = depth(parent_record)
    if parent_depth >= MAX_VARIANT_DEPTH:
        raise InvalidInput(
            f"robot '{parent_id}' is a variant {parent_depth} levels deep (counted from its "
            f"catalog robot or uploaded description), and variants are at most "
            f"{MAX_VARIANT_DEPTH} levels deep (MAX_VARIANT_DEPTH): derive this variant from "
            "a shallower ancestor, with the modifications of the levels between added to it"
        )
    if parent_record is None:
        return {"source": "catalog", "id": parent_id}, []
    if parent_depth == 0:
        rebuilds = {k: parent_record[k] for k in REBUILD_KEYS if k in parent_record}
        record = {**rebuilds, "name": name, "warnings": warnings}
        return {"source": "upload", "id": parent_id, "record": record}, []
    step = {"id": parent_id, **{k: parent_record[k] for k in STEP_KEYS if k in parent_record}}
    return dict(parent_record["base"]), [*parent_record["steps"], step]
