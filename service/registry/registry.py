"""The registry: catalog robots and uploaded models, looked up by id.

Catalog robots are loaded once at start-up. Uploaded models live in the durable store; any
process that shares the data directory (a second worker or replica) finds and rebuilds them on
first use, and a deletion anywhere is seen everywhere on the next lookup.
"""

from __future__ import annotations

import logging
import threading
import time
from pathlib import Path
from typing import Any

from service.errors import CatalogRobot, InvalidModel, NotReady, RobotNotFound
from service.registry.build import build_isolated, build_urdf_model
from service.registry.catalog import load_catalog
from service.registry.robot import Robot
from service.registry.store import ModelStore, content_id
from service.registry.urdf_check import Limits, check_urdf

log = logging.getLogger("robodyn.registry")

NOT_FOUND_HINT = "GET /v1/robots lists the valid ids"


class Registry:
    def __init__(self, data_dir: Path, catalog_names: list[str] | None = None,
                 build_timeout_s: float = 30.0, *, limits: Limits | None = None,
                 build_limits: dict[str, Any] | None = None) -> None:
        self.store = ModelStore(data_dir)
        self.catalog_names = catalog_names
        self.build_timeout_s = build_timeout_s
        # Hardening (issue 9): caps of upload validation, and keyword arguments of
        # `build_isolated` (memory_mb, cpu_s, max_nv) for every isolated build.
        self.limits = limits or Limits()
        self.build_limits: dict[str, Any] = dict(build_limits or {})
        self.catalog: dict[str, Robot] = {}
        self.catalog_failures: dict[str, str] = {}
        self.uploads: dict[str, Robot] = {}
        self.ready = False
        self._lock = threading.Lock()

    # -- start-up -------------------------------------------------------------------------

    def load(self) -> None:
        """Load the catalog and every stored upload; then the registry is ready."""
        started = time.perf_counter()
        self.catalog, self.catalog_failures = load_catalog(self.catalog_names)
        for model_id in self.store.ids():
            try:
                self._load_stored(model_id)
            except Exception as exc:  # a bad record must not stop the service
                log.error("stored model %s not loaded: %s", model_id, exc)
        self.ready = True
        log.info("registry ready: %d catalog robots, %d uploads in %.2f s (%d not loaded: %s)",
                 len(self.catalog), len(self.uploads), time.perf_counter() - started,
                 len(self.catalog_failures), ", ".join(sorted(self.catalog_failures)) or "-")

    def _load_stored(self, model_id: str) -> Robot | None:
        record = self.store.read(model_id)
        if record is None:
            return None
        model = build_urdf_model(record["description"], record["root_joint"], record["gravity"])
        robot = Robot(id=model_id, name=record["name"], source="upload",
                      root_joint=record["root_joint"], model=model,
                      warnings=record.get("warnings", []))
        with self._lock:
            self.uploads[model_id] = robot
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
            raise RobotNotFound(f"catalog robot '{robot_id}' could not be loaded on this server "
                                f"({self.catalog_failures[robot_id]}); {NOT_FOUND_HINT}")
        if not self.store.exists(robot_id):  # deleted here or by another replica
            with self._lock:
                self.uploads.pop(robot_id, None)
            raise RobotNotFound(f"no robot has id '{_shown(robot_id)}'; {NOT_FOUND_HINT}")
        robot = self.uploads.get(robot_id)
        if robot is None:  # uploaded through another process sharing the store
            robot = self._load_stored(robot_id)
            if robot is None:
                raise RobotNotFound(f"no robot has id '{_shown(robot_id)}'; {NOT_FOUND_HINT}")
        return robot

    def summaries(self) -> list[dict[str, Any]]:
        if not self.ready:
            raise NotReady("the robot catalog is still loading; retry in a moment")
        out = [r.summary() for r in self.catalog.values()]
        for model_id in self.store.ids():
            record = self.store.read(model_id)
            if record is not None:
                out.append(record["summary"])
        return out

    # -- uploads and deletions ------------------------------------------------------------

    def upload(self, *, urdf: str, root_joint: str, gravity: list[float], name: str | None,
               inertia_check: str) -> tuple[Robot, bool]:
        """Validate, build (out of process) and store an uploaded URDF: (robot, created)."""
        if not self.ready:
            raise NotReady("the robot catalog is still loading; retry in a moment")
        summary = check_urdf(urdf, self.limits)
        if summary.findings and inertia_check == "reject":
            listed = "; ".join(f.message for f in summary.findings[:10])
            more = len(summary.findings) - 10
            raise InvalidModel(
                f"{listed}{f'; and {more} more' if more > 0 else ''}. Send "
                '"inertia_check": "warn" to store the model with these findings as warnings')
        record: dict[str, Any] = {"format": "urdf", "description": urdf,
                                  "root_joint": root_joint, "gravity": list(gravity)}
        model_id = content_id(record)
        if self.store.exists(model_id):
            return self.get(model_id), False
        model = build_isolated(urdf, root_joint, list(gravity), self.build_timeout_s,
                               **self.build_limits)
        warnings = [f.as_dict() for f in summary.findings]
        robot = Robot(id=model_id, name=name or summary.robot_name, source="upload",
                      root_joint=root_joint, model=model, warnings=warnings)
        with robot.data():  # create its first Data here (a second at nv = 128), not on the loop
            pass
        record.update(id=model_id, name=robot.name, inertia_check=inertia_check,
                      warnings=warnings, summary=robot.summary(), created_at=time.time())
        self.store.write(record)
        with self._lock:
            self.uploads[model_id] = robot
        log.info("stored upload %s (%s): nq=%d nv=%d", model_id, robot.name, robot.nq, robot.nv)
        return robot, True

    def delete(self, robot_id: str) -> None:
        if robot_id in self.catalog or robot_id in self.catalog_failures:
            raise CatalogRobot(f"'{robot_id}' is a catalog robot; only uploads can be deleted")
        with self._lock:
            self.uploads.pop(robot_id, None)
        if not self.store.delete(robot_id):
            raise RobotNotFound(f"no uploaded robot has id '{_shown(robot_id)}'; "
                                f"{NOT_FOUND_HINT}")


def _shown(robot_id: str) -> str:
    # Ids are echoed only when short and printable; anything else is summarized.
    if len(robot_id) <= 64 and robot_id.isprintable():
        return robot_id
    return robot_id[:32].encode("ascii", "replace").decode() + "…"
