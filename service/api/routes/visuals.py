"""Routes that show a robot: its visual elements and the mesh files they reference.

`GET /v1/robots/{id}/visuals` lists every visual element (`service.registry.visuals`), and
`GET /v1/robots/{id}/assets/{path}` serves a mesh file one of them names. The file is found by
looking `path` up in the robot's own `asset_paths` (exactly the files its visuals reference):
the request never becomes part of a filesystem path, so no `..`, absolute path or encoded trick
reaches anything else, and collision meshes or description files are simply not in the table.
Answers carry a content-derived ETag and may be cached for a week; `If-None-Match` gives 304.
The file is streamed from disk in chunks (never read whole into memory).
World placements of the frames come from `POST /v1/robots/{id}/frame-placements`, a dynamics
endpoint (`service.dynamics.placements`).
"""

from __future__ import annotations

import hashlib
import os
import threading
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any, BinaryIO

from fastapi import APIRouter, Request, Response
from fastapi.responses import StreamingResponse
from starlette.concurrency import run_in_threadpool

from service.api.deps import RegistryDep, served_robot
from service.api.encoding.answers import JSONAnswer
from service.api.schemas.common import Problem
from service.api.schemas.visuals import Visuals
from service.errors import AssetNotFound
from service.registry import Registry
from service.registry.robot import Robot
from service.registry.visuals import ensure_visuals

router = APIRouter(prefix="/v1/robots", tags=["robots"])

MEDIA_TYPES = {
    ".stl": "model/stl",
    ".obj": "model/obj",
    ".dae": "model/vnd.collada+xml",
    ".glb": "model/gltf-binary",
}
MAX_AGE_S = 7 * 24 * 3600  # a week; the ETag makes a revalidation cheap after that
_SHOWN = 64
CHUNK_BYTES = 256 * 1024  # a mesh is sent from its file this many bytes at a time

_etags: dict[tuple[Path, int, int], str] = {}  # (file, size, mtime_ns) → ETag
_etags_lock = threading.Lock()


def media_type(path: str) -> str:
    """The media type of a mesh file by its extension (case-insensitive)."""
    return MEDIA_TYPES.get(Path(path).suffix.lower(), "application/octet-stream")


def _open_with_etag(file: Path) -> tuple[BinaryIO, int, str]:
    """The file opened for reading, its size and its ETag (a quoted prefix of its SHA-256,
    computed once per file version by reading it in chunks). Blocking. An open file stays
    readable if the file is removed meanwhile (a deleted upload's assets being collected)."""
    fh = file.open("rb")
    try:
        stat = os.fstat(fh.fileno())
        key = (file, stat.st_size, stat.st_mtime_ns)
        with _etags_lock:
            etag = _etags.get(key)
        if etag is None:
            etag = f'"{hashlib.file_digest(fh, "sha256").hexdigest()[:32]}"'
            fh.seek(0)
            with _etags_lock:
                _etags[key] = etag
    except BaseException:
        fh.close()
        raise
    return fh, stat.st_size, etag


async def _chunks(fh: BinaryIO) -> AsyncIterator[bytes]:
    """The file's bytes, `CHUNK_BYTES` at a time, each read off the event loop; closes it. The
    next chunk is read only once the previous one was handed to the connection, so a client
    that does not read holds at most about a chunk and the socket's buffers, not the file."""
    try:
        while chunk := await run_in_threadpool(fh.read, CHUNK_BYTES):
            yield chunk
    finally:
        fh.close()


def _known_etag(file: Path) -> str | None:
    """The ETag computed before for the file as it is now, if any (no read). Blocking (stat)."""
    stat = file.stat()
    with _etags_lock:
        return _etags.get((file, stat.st_size, stat.st_mtime_ns))


def _matches(if_none_match: str, etag: str) -> bool:
    """RFC 9110 weak comparison of an If-None-Match list with the ETag."""
    tags = [t.strip() for t in if_none_match.split(",")]
    return "*" in tags or etag in (t.removeprefix("W/") for t in tags)


def _robot_visuals(registry: Registry, robot: Robot) -> Robot:
    """`robot` with its visuals computed (parses its stored description once). Blocking."""
    ensure_visuals(robot, registry.get, registry.store.read)
    return robot


async def _with_visuals(registry: Registry, robot_id: str) -> Robot:
    robot = await served_robot(registry, robot_id)
    if robot.visuals is None:  # an upload's first request: parse it off the event loop
        await run_in_threadpool(_robot_visuals, registry, robot)
    return robot


@router.get(
    "/{robot_id}/visuals",
    response_model=Visuals,
    name="visuals",
    responses={404: {"model": Problem, "description": "robot_not_found"}},
    summary="Every visual element of a robot: mesh or primitive, placement in its "
    "link's body frame, scale and colour",
)
async def visuals(robot_id: str, registry: RegistryDep) -> Response:
    """The robot's visual elements as its description gives them. Each is attached to the
    body frame `frame` of its link: its world placement is that frame's placement (from
    `frame-placements`) composed with `placement`. Meshes are fetched from
    `GET /v1/robots/{id}/assets/{asset}`. An empty list: the description has no visuals."""
    robot = await _with_visuals(registry, robot_id)
    return JSONAnswer({"visuals": robot.visuals})


@router.get(
    "/{robot_id}/assets/{path:path}",
    name="asset",
    responses={
        200: {
            "content": {t: {} for t in MEDIA_TYPES.values()},
            "description": "the mesh file's bytes",
        },
        304: {"description": "not modified (If-None-Match)"},
        404: {"model": Problem, "description": "robot_not_found, asset_not_found"},
    },
    summary="A mesh file the robot's visuals reference",
)
async def asset(robot_id: str, path: str, request: Request, registry: RegistryDep) -> Response:
    """The bytes of the mesh named `path` (exactly a visual's `asset` string), with its media
    type, an ETag and `Cache-Control`. Any other path is a 404 `asset_not_found`."""
    robot = await _with_visuals(registry, robot_id)
    file = robot.asset_paths.get(path)
    if file is None:
        shown = path if len(path) <= _SHOWN and path.isprintable() else "of that name"
        raise AssetNotFound(
            f"robot '{robot.id}' has no asset '{shown}'; the mesh files it "
            f"serves are the `asset`s of GET /v1/robots/{robot.id}/visuals"
        )
    try:
        return await _file_answer(request, file, path)
    except OSError:  # gone since the robot was loaded (a deleted upload, say)
        raise AssetNotFound(
            f"the asset '{path[:_SHOWN]}' of robot '{robot.id}' is no longer available"
        ) from None


async def _file_answer(request: Request, file: Path, path: str) -> Response:
    scope = "private" if request.app.state.settings.api_keys_scope == "all" else "public"
    headers: dict[str, Any] = {"Cache-Control": f"{scope}, max-age={MAX_AGE_S}"}
    if_none_match = request.headers.get("if-none-match")
    if if_none_match:
        known = await run_in_threadpool(_known_etag, file)
        if known is not None and _matches(if_none_match, known):
            return Response(status_code=304, headers={**headers, "ETag": known})
    fh, size, etag = await run_in_threadpool(_open_with_etag, file)
    if if_none_match and _matches(if_none_match, etag):
        fh.close()
        return Response(status_code=304, headers={**headers, "ETag": etag})
    return StreamingResponse(
        _chunks(fh),
        media_type=media_type(path),
        headers={**headers, "ETag": etag, "Content-Length": str(size)},
    )
