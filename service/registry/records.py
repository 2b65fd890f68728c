"""The schema of the store's records: what `ModelStore.read` accepts as a model record.

A record is read only through `check_record`, so a file that is valid JSON but incomplete or
mistyped (no `summary`, a `description` that is not text, ...) is skipped like a corrupt one:
one log line, never an error on every listing. Unknown members are allowed (records written by
newer versions, e.g. stored assets), so the schema checks only what this version reads.

Two kinds of record:
- a description (`format` "urdf", "mjcf" or "xacro"): `description` text, `root_joint`,
  `gravity` (3 numbers, m/s², or null for an MJCF's own), `name`, `warnings`, `summary`, and
  where the upload has them `assets` (key → SHA-256), `xacro_args`, `expanded_urdf` (what
  rebuilds a xacro: the server never expands one outside a builder process), `visuals`;
- a reduced model (`format` "reduced"): `base` (what rebuilds the base: a catalog name, or an
  upload's id with its record embedded), `locked_joints` (joint name → positions), `name`,
  `warnings`, `summary`;
- a variant carrying payloads (`format` "variant"): `base` as above, `payloads` (at least one:
  `frame`, `mass`, `center_of_mass`, `inertia`, checked when stored), `locked_joints` (may be
  empty), `name`, `warnings`, `summary`.
Reduced models and variants also keep `locked_request` and `modifications` (as requested).
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError


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


class _Embedded(_Member):
    """What rebuilds a model (a record embedded in a reduced model's `base`)."""

    format: str
    name: str | None = None
    warnings: list[dict[str, Any]] = []


class EmbeddedDescription(_Embedded):
    description: str
    root_joint: str
    # None: an MJCF's own <option gravity>
    gravity: list[float] | None = Field(min_length=3, max_length=3)
    assets: dict[str, str] | None = None  # asset key -> SHA-256 of the stored file
    xacro_args: dict[str, str] | None = None
    expanded_urdf: str | None = None  # a xacro's expansion: what rebuilds it
    visuals: list[dict[str, Any]] | None = None  # an MJCF's visuals (from MuJoCo)


class EmbeddedReduced(_Embedded):
    format: Literal["reduced"]
    base: BaseSpec
    locked_joints: dict[str, list[float]]


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


class EmbeddedVariant(_Embedded):
    format: Literal["variant"]
    base: BaseSpec
    payloads: list[StoredPayload] = []
    locked_joints: dict[str, list[float]] = {}
    # identified values (service.registry.variants.Fitted)
    inertial_parameters: list[float] | None = None
    friction: list[StoredFriction] | None = None


class BaseSpec(_Member):
    """The base of a reduced model: a catalog robot by name, or an upload with its record."""

    source: Literal["catalog", "upload"]
    id: str
    record: EmbeddedReduced | EmbeddedVariant | EmbeddedDescription | None = None


EmbeddedReduced.model_rebuild()
EmbeddedVariant.model_rebuild()


class DescriptionRecord(EmbeddedDescription):
    id: str
    name: str
    summary: Summary


class ReducedRecord(EmbeddedReduced):
    id: str
    name: str
    summary: Summary


class VariantRecord(EmbeddedVariant):
    id: str
    name: str
    summary: Summary


_KINDS: dict[str, type[_Member]] = {"reduced": ReducedRecord, "variant": VariantRecord}


def check_record(record: Any, model_id: str) -> dict[str, Any]:
    """`record` itself if it is a complete record of model `model_id`; otherwise ValueError
    with a one-line reason (the first problem found)."""
    if not isinstance(record, dict):
        raise ValueError("the record is not a JSON object")
    if record.get("id") != model_id:
        raise ValueError("the record does not match its file name")
    kind = _KINDS.get(str(record.get("format")), DescriptionRecord)
    try:
        kind.model_validate(record)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "record"
        more = f" (and {exc.error_count() - 1} more)" if exc.error_count() > 1 else ""
        raise ValueError(f"incomplete record: {where}: {first['msg']}{more}") from None
    return record
