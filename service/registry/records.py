"""The schema of the store's records: what `ModelStore.read` accepts as a model record.

A record is read only through `check_record`, so a file that is valid JSON but incomplete or
mistyped (no `summary`, a `description` that is not text, ...) is skipped like a corrupt one:
one log line, never an error on every listing. Unknown members are allowed (records written by
newer versions, e.g. stored assets), so the schema checks only what this version reads.

Two kinds of record:
- a description (`format` "urdf", "mjcf" or "xacro"): `description` text, `root_joint`,
  `gravity` (3 numbers, m/s², or null for an MJCF's own), `name`, `warnings`, `summary`, and
  where the upload has them `assets` (key → SHA-256), `xacro_args`, `expanded_urdf` (what
  rebuilds a xacro: the server never expands one outside a builder process), `visuals`,
  `inertia_repairs` (`inertia_check: "repair"`: `service.registry.link_inertias`);
- a variant (`format` "reduced" for locked joints alone, else "variant"): its own
  modifications, `payloads` (at least one for "variant": `frame`, `mass`, `center_of_mass`,
  `inertia`, checked when stored), `locked_joints` (joint name → positions; required for "reduced"),
  identified `inertial_parameters` and `friction`, `inertia_repairs`, then `name`, `warnings`,
  `summary`, and its lineage, flat: `base`, the root it derives from (a catalog robot by name, or an
  upload by id with the members of its description record that rebuild it), and `steps`, the
  variants between that root and the variant's parent, root first, each with its `id` and its own
  modifications (`Step`). The parent is the last step (the root without steps). A variant also keeps
  `locked_request` and `modifications` (as requested).

Records written in the nested form (a variant's `base.record` holding its parent's whole
record, itself nesting its parent's, down to the root) are flattened on read (`flat`) before
they are checked, so checking a record costs time linear in its size whatever its depth.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

VARIANT_FORMATS = ("reduced", "variant")
STEP_KEYS = (
    "format",
    "name",
    "warnings",
    "locked_joints",
    "payloads",
    "inertial_parameters",
    "friction",
    "inertia_repairs",
    "modifications",
)
"""The members of a variant's record that its `Step` in a descendant's lineage keeps."""


class _Member(BaseModel):
    model_config = ConfigDict(extra="allow", strict=True)


class Summary(_Member):
    """The entry of the robot in GET /v1/robots."""

    id: str
    name: str
    source: str
    nq: int = Field(ge=0)
    nv: int = Field(ge=0)
    root_joint: str


class EmbeddedDescription(_Member):
    """What rebuilds an uploaded description (the root of a variant's lineage)."""

    format: str
    name: str | None = None
    warnings: list[dict[str, Any]] = []
    description: str
    root_joint: str
    # None: an MJCF's own <option gravity>
    gravity: list[float] | None = Field(min_length=3, max_length=3)
    assets: dict[str, str] | None = None  # asset key -> SHA-256 of the stored file
    xacro_args: dict[str, str] | None = None
    expanded_urdf: str | None = None  # a xacro's expansion: what rebuilds it
    visuals: list[dict[str, Any]] | None = None  # an MJCF's visuals (from MuJoCo)
    # `inertia_check: "repair"`: the links' inertials replaced (service.registry.link_inertias)
    inertia_repairs: list[dict[str, Any]] | None = None


class StoredPayload(_Member):
    """A payload of a variant (kg, m, kg·m²; see `service.registry.payloads`)."""

    frame: str
    mass: float = Field(gt=0)
    center_of_mass: list[float] = Field(min_length=3, max_length=3)
    inertia: list[list[float]] = Field(min_length=3, max_length=3)


class StoredFriction(_Member):
    """An identified joint's friction (N·m or N, N·m·s/rad or N·s/m)."""

    joint: str
    coulomb: float
    viscous: float
    offset: float


class _Modifications(_Member):
    """A variant's own modifications (`service.registry.variants`)."""

    name: str | None = None
    warnings: list[dict[str, Any]] = []
    payloads: list[StoredPayload] = []
    locked_joints: dict[str, list[float]] = {}
    # identified values (service.registry.variants.Fitted)
    inertial_parameters: list[float] | None = None
    friction: list[StoredFriction] | None = None
    # repaired link inertials (service.registry.link_inertias)
    inertia_repairs: list[dict[str, Any]] | None = None


class Step(_Modifications):
    """One variant of a lineage: its id and its own modifications."""

    id: str
    format: Literal["reduced", "variant"]


class BaseSpec(_Member):
    """The root of a lineage: a catalog robot by name, or an upload with its record."""

    source: Literal["catalog", "upload"]
    id: str
    record: EmbeddedDescription | None = None


class DescriptionRecord(EmbeddedDescription):
    id: str
    name: str
    summary: Summary


class _LineageRecord(_Modifications):
    id: str
    name: str
    summary: Summary
    base: BaseSpec
    steps: list[Step] = []


class VariantRecord(_LineageRecord):
    format: Literal["variant"]


class ReducedRecord(_LineageRecord):
    format: Literal["reduced"]
    locked_joints: dict[str, list[float]]


_KINDS: dict[str, type[_Member]] = {"reduced": ReducedRecord, "variant": VariantRecord}


def flat(record: dict[str, Any]) -> dict[str, Any]:
    """A variant's record in the flat form: `record` itself if it has `steps` or is not a
    variant; else its nested `base` (each level's `record` holding the parent's record) walked
    down to the root, one `Step` per variant met (without reading anything twice). Whatever
    is not the expected shape is left where it is found, for `check_record` to name."""
    if record.get("format") not in VARIANT_FORMATS or "steps" in record:
        return record
    steps: list[dict[str, Any]] = []
    spec = record.get("base")
    while isinstance(spec, dict):
        parent = spec.get("record")
        if not isinstance(parent, dict) or parent.get("format") not in VARIANT_FORMATS:
            break
        steps.append({"id": spec.get("id"), **{k: parent[k] for k in STEP_KEYS if k in parent}})
        spec = parent.get("base")
    steps.reverse()
    return {**record, "base": spec, "steps": steps}


def check_record(record: Any, model_id: str) -> dict[str, Any]:
    """`record` (a variant's in the flat form) if it is a complete record of model
    `model_id`; otherwise ValueError with a one-line reason (the first problem found)."""
    if not isinstance(record, dict):
        raise ValueError("the record is not a JSON object")
    if record.get("id") != model_id:
        raise ValueError("the record does not match its file name")
    checked: dict[str, Any] = flat(record)
    kind = _KINDS.get(str(checked.get("format")), DescriptionRecord)
    try:
        kind.model_validate(checked)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "record"
        more = f" (and {exc.error_count() - 1} more)" if exc.error_count() > 1 else ""
        raise ValueError(f"incomplete record: {where}: {first['msg']}{more}") from None
    return checked
