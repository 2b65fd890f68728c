"""The registry: catalog robots and uploaded models, looked up by id.

Catalog robots are loaded once at start-up; then the registry is ready. Uploaded models
(URDF, MJCF, and variants of any robot: payloads and/or locked joints,
`service.registry.variants`) live in the durable store, and every process that shares the data
directory (this one after a restart, a second worker or replica) builds each from its record
on first use: start-up reads no record, and a model never asked for is never built. A deletion
anywhere is seen everywhere on the next lookup. A variant's record holds its lineage, flat
(`service.registry.lineage`: the root's record or catalog name, and each variant between), so
it survives the deletion of its parent and rebuilds in time linear in its depth.

The robot list is served in pages (`service.registry.robot_pages`) from the summaries of the
stored records, each read once (records never change under their id).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from service.errors import CatalogRobot, InvalidInput, NotReady, RobotNotFound, did_you_mean
from service.registry.assets import AssetStore, decode_assets
from service.registry.build import build_model, check_moves, reference_configurations
from service.registry.build_process import build_upload
from service.registry.build_slots import BuildSlots, build_slot_count
from service.registry.catalog import catalog_check_inputs, load_catalog
from service.registry.check_inputs import (
    CheckInputs,
    fitted_lineage,
    identified_inputs,
    lineage_repairs,
    upload_inputs,
)
from service.registry.lineage import Lineage, child_lineage
from service.registry.link_inertias import repaired_warnings, with_link_inertias
from service.registry.payloads import PlacedPayload
from service.registry.records import VARIANT_FORMATS
from service.registry.reduce import LockedValue, as_lists, locked_configuration
from service.registry.robot import Robot
from service.registry.robot_pages import MAX_PAGE, Page, page
from service.registry.store import ModelStore, content_id
from service.registry.upload_formats import (
    after_build,
    check_findings,
    mesh_paths,
    new_record,
    rebuild_inputs,
)
from service.registry.urdf_check import Limits
from service.registry.variants import (
    NOTHING_FITTED,
    Fitted,
    modifications,
    variant_id,
    variant_robot,
)
from service.settings import Settings

log = logging.getLogger("robodyn.registry")

NOT_FOUND_HINT = "GET /v1/robots lists the valid ids"


class Registry:
    def __init__(
        self,
        data_dir: Path,
        catalog_names: list[str] | None = None,
        build_timeout_s: float = Settings.model_fields["build_timeout_s"].default,
        *,
        limits: Limits | None = None,
        build_limits: dict[str, Any] | None = None,
        build_slots: BuildSlots | None = None,
    ) -> None:
        self.store = ModelStore(data_dir)
        self.assets = AssetStore(data_dir)
        self.catalog_names = catalog_names
        self.build_timeout_s = build_timeout_s
        # Hardening: caps of upload validation, and keyword arguments of
        # `build_isolated` (memory_mb, cpu_s, max_nv) for every isolated build.
        self.limits = limits or Limits()
        self.build_limits: dict[str, Any] = dict(build_limits or {})
        # Build contention: at most this many builds at once (the CPU count by default), waiting for
        # a slot is bounded and answered 503 overloaded, never invalid_model.
        self.build_slots = build_slots or BuildSlots(build_slot_count(0), build_timeout_s)
        self.catalog: dict[str, Robot] = {}
        self.catalog_failures: dict[str, str] = {}
        self.uploads: dict[str, Robot] = {}  # stored models built here, by id
        # ancestors built to rebuild a variant: catalog robots not served here, the root and
        # the steps of lineages (`_lineage_parent`)
        self._bases: dict[str, Robot] = {}
        self.ready = False
        self._lock = threading.Lock()
        self._summaries: dict[str, dict[str, Any]] = {}  # stored id → summary (read once)
        self._summaries_lock = threading.Lock()
        self._asset_shas: dict[str, frozenset[str]] = {}  # stored id → the assets it names
        self._asset_shas_lock = threading.Lock()

    # -- start-up -------------------------------------------------------------------------

    def load(self) -> None:
        """Load the catalog; then the registry is ready. Stored models are built on first use
        (`get`), so start-up takes the same time whatever the store holds."""
        started = time.perf_counter()
        self.catalog, self.catalog_failures = load_catalog(self.catalog_names)
        self.ready = True
        log.info(
            "registry ready: %d catalog robots in %.2f s (%d not loaded: %s); %d stored models, "
            "each built on first use",
            len(self.catalog),
            time.perf_counter() - started,
            len(self.catalog_failures),
            ", ".join(sorted(self.catalog_failures)) or "-",
            len(self.store.ids()),
        )

    def _load_stored(self, model_id: str) -> Robot | None:
        record = self.store.read(model_id)
        if record is None:
            return None
        robot = self._robot_from_record(model_id, record)
        with self._lock:
            self.uploads[model_id] = robot
        return robot

    def _robot_from_record(self, model_id: str, record: Mapping[str, Any]) -> Robot:
        """Rebuild a stored model in process (its description was validated when uploaded; a
        variant's `record` is in the flat form `ModelStore.read` gives)."""
        fmt = record.get("format", "urdf")
        if fmt in VARIANT_FORMATS:
            parent = self._lineage_parent(record["base"], record["steps"])
            return _variant_of(parent, model_id, record)
        fmt, text, assets = rebuild_inputs(record, self.assets)
        model = build_model(fmt, text, record["root_joint"], record["gravity"], assets)
        if record.get("inertia_repairs"):
            model = with_link_inertias(model, record["inertia_repairs"])
        check_moves(model)  # a record stored before nv = 0 was refused is not served
        return Robot(
            id=model_id,
            name=record.get("name", model_id),
            source="upload",
            root_joint=record.get("served_root_joint", record["root_joint"]),
            model=model,
            reference_configurations=reference_configurations(model),
            warnings=record.get("warnings", []),
            visuals=record.get("visuals"),
            asset_paths=mesh_paths(self.assets, record),
            mujoco_qpos=fmt == "mjcf",
        )

    def _lineage_parent(self, base: Mapping[str, Any], steps: Sequence[Mapping[str, Any]]) -> Robot:
        """The parent of a variant whose lineage is (base, steps): from the deepest of its
        ancestors built here already, each step after it built once (and kept)."""
        start, robot = len(steps), None
        while start > 0 and robot is None:
            start -= 1
            robot = self.uploads.get(steps[start]["id"]) or self._bases.get(steps[start]["id"])
        if robot is None:
            start, robot = -1, self._base_robot(base)
        for step in steps[start + 1 :]:
            robot = _variant_of(robot, step["id"], step)
            with self._lock:
                self._bases[step["id"]] = robot
        return robot

    def _base_robot(self, spec: Mapping[str, Any]) -> Robot:
        """The root of a lineage: a catalog robot (loaded here if this server does not serve
        it) or an upload (served here, or rebuilt from the record in `spec`)."""
        base_id = spec["id"]
        robot = (
            self.catalog.get(base_id) if spec["source"] == "catalog" else self.uploads.get(base_id)
        ) or self._bases.get(base_id)
        if robot is None:
            if spec["source"] == "catalog":
                loaded, failures = load_catalog([base_id])
                if base_id not in loaded:
                    raise RuntimeError(
                        f"catalog robot {base_id} not loadable: {failures.get(base_id)}"
                    )
                robot = loaded[base_id]
            else:
                robot = self._robot_from_record(base_id, spec["record"])
            with self._lock:
                self._bases[base_id] = robot
        return robot

    # -- lookup ---------------------------------------------------------------------------

    def get(self, robot_id: str) -> Robot:
        """The robot with this id; `RobotNotFound` (naming where valid ids are) otherwise."""
        if not self.ready:
            raise NotReady("the robot catalog is still loading; retry in a moment")
        robot = self.catalog.get(robot_id)
        if robot is not None:
            return robot
        if robot_id in self.catalog_failures:
            raise RobotNotFound(
                f"catalog robot '{robot_id}' could not be loaded on this server "
                f"({self.catalog_failures[robot_id]}); {NOT_FOUND_HINT}"
            )
        if not self.store.exists(robot_id):  # deleted here or by another replica
            with self._lock:
                self.uploads.pop(robot_id, None)
            close = did_you_mean(robot_id, self.catalog)
            raise RobotNotFound(f"no robot has id '{_shown(robot_id)}'{close}; {NOT_FOUND_HINT}")
        robot = self.uploads.get(robot_id)
        if robot is None:  # uploaded through another process sharing the store
            try:
                robot = self._load_stored(robot_id)
            except Exception as exc:  # a record this server cannot rebuild: logged, not a 500
                log.error("stored model %s not loaded: %s", robot_id, exc)
                raise RobotNotFound(
                    f"stored model '{_shown(robot_id)}' could not be rebuilt on "
                    "this server (see its log)"
                ) from None
            if robot is None:
                raise RobotNotFound(f"no robot has id '{_shown(robot_id)}'; {NOT_FOUND_HINT}")
        return robot

    def built(self, robot_id: str) -> bool:
        """Whether `get(robot_id)` answers without building a model (a catalog robot, a stored
        model already built, or an id it refuses at once): when False, `get` may build a
        stored model from its record, which takes milliseconds to seconds."""
        return (
            not self.ready
            or robot_id in self.catalog
            or robot_id in self.uploads
            or robot_id in self.catalog_failures
        )

    def check_inputs(self, robot_id: str) -> CheckInputs:
        """What the model check of robot `robot_id` reads (`service.registry.check_inputs`):
        its root description, meshes and the inertia repairs along its lineage. Blocking
        (reads the store): call it off the event loop."""
        robot = self.get(robot_id)
        if robot.source == "catalog":
            return catalog_check_inputs(robot.id, robot.model, ())
        record = self.store.read(robot.id)
        if record is None:
            raise RobotNotFound(f"no robot has id '{_shown(robot_id)}'; {NOT_FOUND_HINT}")
        repairs = lineage_repairs(record)
        base = record.get("base") if record.get("format") in VARIANT_FORMATS else None
        if base is not None and base["source"] == "catalog":
            inputs = catalog_check_inputs(base["id"], robot.model, repairs)
        else:
            description = record if base is None else base["record"]
            inputs = upload_inputs(description, robot.model, repairs, assets=self.assets)
        return identified_inputs(inputs, robot.model) if fitted_lineage(record) else inputs

    def robot_page(self, limit: int, cursor: str | None = None) -> Page:
        """A page of the robot list (`robot_pages.page`): catalog first, then stored models by
        id. Blocking (it lists the store's directory and reads the records of the page not
        read yet): call it off the event loop."""
        if not self.ready:
            raise NotReady("the robot catalog is still loading; retry in a moment")
        catalog = [r.summary() for r in self.catalog.values()]
        ids = self.store.ids()
        with self._summaries_lock:
            for gone in set(self._summaries).difference(ids):
                del self._summaries[gone]
            return page(catalog, ids, self._summary, limit, cursor)

    def summaries(self) -> list[dict[str, Any]]:
        """Every served robot's summary, in the order of the list's pages. Blocking."""
        out, cursor = [], None
        while True:
            listed = self.robot_page(MAX_PAGE, cursor)
            out += listed.robots
            if listed.next_cursor is None:
                return out
            cursor = listed.next_cursor

    def _summary(self, model_id: str) -> dict[str, Any] | None:
        """A stored model's summary, None for an unreadable record. Records never change
        under their id (it is derived from their content), so each is read once; the listing
        still sees other replicas' uploads and deletions. Under `_summaries_lock`."""
        summary = self._summaries.get(model_id)
        if summary is None:
            record = self.store.read(model_id)
            if record is None:
                return None
            summary = self._summaries[model_id] = record["summary"]
        return summary

    # -- uploads and deletions ------------------------------------------------------------

    def upload(
        self,
        *,
        urdf: str | None = None,
        mjcf: str | None = None,
        root_joint: str,
        gravity: list[float] | None,
        name: str | None,
        inertia_check: str,
        locked_joints: Mapping[str, LockedValue] | None = None,
        xacro: str | None = None,
        xacro_args: Mapping[str, str] | None = None,
        assets: Mapping[str, str] | None = None,
        repair: Callable[[CheckInputs], list[dict[str, Any]]] | None = None,
    ) -> tuple[Robot, bool]:
        """Validate, build (out of process) and store an uploaded URDF, MJCF or xacro (with
        `locked_joints`: its reduced model, stored alone): (robot, created). `assets`: path →
        base64 of the files it references; `gravity` None: the description's own
        (`upload_formats`). With `inertia_check` "repair", `repair(inputs)` gives the repairs
        of the links whose inertials have an error (the model check's), stored with the
        record and applied to the model."""
        if not self.ready:
            raise NotReady("the robot catalog is still loading; retry in a moment")
        given = [
            (f, t) for f, t in (("urdf", urdf), ("mjcf", mjcf), ("xacro", xacro)) if t is not None
        ]
        if len(given) != 1:
            raise ValueError("give exactly one of urdf, mjcf and xacro")
        fmt, text = given[0]
        files = decode_assets(assets)
        record = new_record(fmt, text, root_joint, gravity, files, xacro_args)
        # Validation, a xacro's expansion and the native build run in a builder process (never
        # in this one: on a large description they would hold its GIL for seconds), one build
        # slot each.
        with self.build_slots.slot():
            built = build_upload(
                text,
                root_joint,
                record["gravity"],
                self.build_timeout_s,
                description_format=fmt,
                limits=self.limits,
                reject_findings=inertia_check == "reject",
                assets=files,
                xacro_args=xacro_args,
                **self.build_limits,
            )
        checked = built.checked
        check_findings(checked.findings, inertia_check)
        model = built.model
        repairs: list[dict[str, Any]] = []
        if inertia_check == "repair" and model is not None:
            if repair is None:
                raise ValueError('inertia_check "repair" needs the model check\'s repair')
            described = {**record, "expanded_urdf": built.report.get("expanded_urdf")}
            repairs = repair(upload_inputs(described, model, (), mesh_data=files))
            if repairs:
                record["inertia_repairs"] = repairs
                model = with_link_inertias(model, repairs)
        model_id = content_id(record)
        request = None if locked_joints is None else as_lists(locked_joints)
        target = model_id if request is None else variant_id(model_id, (), request)
        if self.store.exists(target):
            return self.get(target), False
        assert model is not None  # built unless findings were rejected (above)
        warnings = repaired_warnings(
            after_build(record, built.report, model, checked, self.limits), repairs
        )
        robot = Robot(
            id=model_id,
            name=name or checked.label,
            source="upload",
            root_joint=record.get("served_root_joint", root_joint),
            model=model,
            reference_configurations=reference_configurations(model),
            warnings=warnings,
            visuals=record.get("visuals"),
            asset_paths=mesh_paths(self.assets, record),
            mujoco_qpos=fmt == "mjcf",
        )
        with robot.data():  # create its first Data here (a second at nv = 128), not on the loop
            pass
        robot.info()  # and its description (thousands of frames for a large model)
        with self.assets.storing():  # the files are named by a record before any sweep
            self.assets.put(files)
            if request is not None:
                lineage = child_lineage(model_id, record, robot.name, warnings)
                return self._store_variant(robot, lineage, (), request, name), True
            record.update(
                id=model_id,
                name=robot.name,
                inertia_check=inertia_check,
                warnings=warnings,
                summary=robot.summary(),
                created_at=time.time(),
            )
            self.store.write(record)
        with self._lock:
            self.uploads[model_id] = robot
        log.info("stored upload %s (%s): nq=%d nv=%d", model_id, robot.name, robot.nq, robot.nv)
        return robot, True

    def reduce(
        self, robot_id: str, locked_joints: Mapping[str, LockedValue], name: str | None = None
    ) -> tuple[Robot, bool]:
        """Store the reduced model of any robot with `locked_joints` locked: (robot, created).
        The variant with locked joints alone (`variant`)."""
        if not locked_joints:
            raise InvalidInput("locked_joints is empty; name at least one joint to lock")
        return self.variant(robot_id, locked_joints=locked_joints, name=name)

    def variant(
        self,
        robot_id: str,
        *,
        payloads: Sequence[PlacedPayload] = (),
        locked_joints: Mapping[str, LockedValue] | None = None,
        name: str | None = None,
        fitted: Fitted | None = None,
        inertias: Mapping[str, Any] | None = None,
    ) -> tuple[Robot, bool]:
        """Store the variant of any robot carrying `payloads` (checked against that robot by
        `service.dynamics.payloads.check_payloads`) with `locked_joints` locked, the
        identified values `fitted` (checked by identification), and the repaired link
        inertials `inertias` ({"links", "from", "repairs"}: computed against that robot by the
        model check): (robot, created). At least one modification; `InvalidInput` otherwise."""
        if not payloads and not locked_joints and not fitted and not inertias:
            raise InvalidInput(
                "a variant needs at least one modification: payloads, locked_joints or inertias"
            )
        base = self.get(robot_id)
        request = as_lists(locked_joints or {})
        fitted = fitted or NOTHING_FITTED
        target = variant_id(base.id, payloads, request, fitted, inertias)
        if self.store.exists(target):
            return self.get(target), False
        # the base's assets stay named from reading its record until the variant's is written
        with self.assets.storing():
            record = None
            if base.source != "catalog":
                record = self.store.read(base.id)
                if record is None:
                    raise RobotNotFound(f"no robot has id '{_shown(robot_id)}'; {NOT_FOUND_HINT}")
            lineage = child_lineage(base.id, record, base.name, base.warnings)
            return self._store_variant(
                base, lineage, payloads, request, name, fitted, inertias
            ), True

    def _store_variant(
        self,
        base: Robot,
        lineage: Lineage,
        payloads: Sequence[PlacedPayload],
        request: dict[str, list[float]],
        name: str | None,
        fitted: Fitted | None = None,
        inertias: Mapping[str, Any] | None = None,
    ) -> Robot:
        fitted = fitted or NOTHING_FITTED
        locked = locked_configuration(base, request) if request else {}
        model_id = variant_id(base.id, payloads, request, fitted, inertias)
        changes = modifications(payloads, request, fitted, inertias)
        kind = "variant" if payloads or fitted or inertias else "reduced"
        repairs = list((inertias or {}).get("repairs", []))
        robot = variant_robot(
            base,
            payloads,
            locked,
            robot_id=model_id,
            name=name or f"{base.name} ({kind})",
            changes=changes,
            fitted=fitted,
            inertia_repairs=repairs,
        )
        record: dict[str, Any] = {
            "format": kind,
            "base": lineage[0],
            "steps": lineage[1],
            "locked_joints": locked,
            "locked_request": request,
            "modifications": changes,
            "id": model_id,
            "name": robot.name,
            "warnings": robot.warnings,
            "summary": robot.summary(),
            "created_at": time.time(),
        }
        if payloads:
            record["payloads"] = changes["payloads"]
        if repairs:
            record["inertia_repairs"] = repairs
        record.update(fitted.record())
        self.store.write(record)
        with self._lock:
            self.uploads[model_id] = robot
        log.info(
            "stored %s model %s of %s: nq=%d nv=%d", kind, model_id, base.id, robot.nq, robot.nv
        )
        return robot

    def delete(self, robot_id: str) -> None:
        if robot_id in self.catalog or robot_id in self.catalog_failures:
            raise CatalogRobot(f"'{robot_id}' is a catalog robot; only uploads can be deleted")
        with self._lock:
            self.uploads.pop(robot_id, None)
        if not self.store.delete(robot_id):
            raise RobotNotFound(f"no uploaded robot has id '{_shown(robot_id)}'; {NOT_FOUND_HINT}")
        self.assets.collect(self._named_assets)

    def _named_assets(self) -> set[str]:
        """The SHA-256 of every asset file a stored record names (its own, or its base's for a
        reduced model). Records never change under their id, so each is read once."""
        ids = self.store.ids()
        named: set[str] = set()
        with self._asset_shas_lock:
            for model_id in ids:
                shas = self._asset_shas.get(model_id)
                if shas is None:
                    record = self.store.read(model_id)
                    if record is None:
                        continue
                    shas = self._asset_shas[model_id] = frozenset(_asset_shas(record))
                named |= shas
            for gone in set(self._asset_shas).difference(ids):
                del self._asset_shas[gone]
        return named


def _asset_shas(record: Mapping[str, Any]) -> Iterator[str]:
    """The SHA-256 of the asset files a record (or its lineage's root, for a variant) names."""
    yield from (record.get("assets") or {}).values()
    base = record.get("base")
    if isinstance(base, Mapping) and isinstance(base.get("record"), Mapping):
        yield from (base["record"].get("assets") or {}).values()


def _variant_of(parent: Robot, model_id: str, record: Mapping[str, Any]) -> Robot:
    """The variant `model_id` of `parent` with the modifications of `record` (a variant's
    record, or a `Step` of a lineage)."""
    locked = {k: [float(x) for x in v] for k, v in record.get("locked_joints", {}).items()}
    payloads = [PlacedPayload.from_dict(p) for p in record.get("payloads", [])]
    fitted = Fitted.from_dict(record)
    changes = record.get("modifications") or modifications(
        payloads, record.get("locked_request", locked), fitted
    )
    return variant_robot(
        parent,
        payloads,
        locked,
        robot_id=model_id,
        name=record.get("name") or model_id,
        changes=changes,
        fitted=fitted,
        inertia_repairs=record.get("inertia_repairs") or (),
    )


def _shown(robot_id: str) -> str:
    # Ids are echoed only when short and printable; anything else is summarized.
    if len(robot_id) <= 64 and robot_id.isprintable():
        return robot_id
    return robot_id[:32].encode("ascii", "replace").decode() + "…"
