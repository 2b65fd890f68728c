"""Routes of the robot catalog and uploads: list, describe, upload, reduce, variants, delete."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, Query, Request, Response
from starlette.concurrency import run_in_threadpool

from service.api.deps import RegistryDep, require_api_key, served_robot
from service.api.encoding.answers import JSONAnswer
from service.api.schemas.body_inertias import Inertias
from service.api.schemas.common import Problem
from service.api.schemas.payloads import VariantRequest
from service.api.schemas.robots import ReduceRequest, RobotInfo, RobotList, UploadRequest
from service.api.upload_body import (
    INLINE_UPLOAD_BYTES,
    read_upload,
    read_upload_isolated,
    upload_request,
)
from service.api.workers.model_check import upload_repairs, variant_repairs
from service.dynamics.body_inertias import body_inertias
from service.dynamics.payloads import check_payloads
from service.registry.robot_pages import DEFAULT_PAGE, MAX_PAGE

router = APIRouter(prefix="/v1/robots", tags=["robots"])

_PROBLEMS: dict[int | str, dict[str, Any]] = {
    404: {"model": Problem, "description": "robot_not_found"},
    422: {"model": Problem, "description": "validation_error, invalid_model"},
}


@router.get(
    "",
    response_model=RobotList,
    responses={422: {"model": Problem, "description": "validation_error (limit, cursor)"}},
    summary="List catalog robots and uploaded models, a page at a time",
)
async def list_robots(
    registry: RegistryDep,
    limit: Annotated[
        int,
        Query(
            ge=1,
            le=MAX_PAGE,
            description=f"The most robots on the page: 1 to {MAX_PAGE}, {DEFAULT_PAGE} by "
            "default (enough for the whole catalog on the first page).",
        ),
    ] = DEFAULT_PAGE,
    cursor: Annotated[
        str | None,
        Query(
            max_length=200,
            description="The `next_cursor` of the previous page; leave it out for the first.",
        ),
    ] = None,
) -> Response:
    """The robots this server serves, a page at a time: the catalog first, then stored
    models by id; follow `next_cursor` until it is null for the whole list."""
    listed = await run_in_threadpool(registry.robot_page, limit, cursor)  # reads the store
    return JSONAnswer(
        {
            "robots": listed.robots,
            "unavailable": registry.catalog_failures,
            "next_cursor": listed.next_cursor,
        }
    )


@router.get(
    "/{robot_id}",
    response_model=RobotInfo,
    responses=_PROBLEMS,
    summary="A robot's joint layout, limits, configurations and findings",
)
async def robot_info(robot_id: str, registry: RegistryDep) -> Response:
    return JSONAnswer((await served_robot(registry, robot_id)).info())


@router.get(
    "/{robot_id}/inertias",
    response_model=Inertias,
    responses={404: _PROBLEMS[404]},
    summary="Every body's mass, centre of mass, inertia (at the centre of mass and at "
    "the joint) and principal moments and axes",
)
async def robot_inertias(robot_id: str, registry: RegistryDep) -> Response:
    """Inertial parameters of every body, each in the frame of the joint that moves it."""
    return JSONAnswer(body_inertias(await served_robot(registry, robot_id)))


_UPLOAD: dict[str, Any] = dict(
    response_model=RobotInfo,
    status_code=201,
    responses={
        200: {"model": RobotInfo, "description": "the model was already stored"},
        401: {"model": Problem},
        413: {"model": Problem},
        **_PROBLEMS,
    },
    summary="Upload a URDF, xacro or MJCF: 201 for a new model, 200 for one already stored",
)


@router.post("", include_in_schema=False, dependencies=[Depends(require_api_key)], **_UPLOAD)
async def upload_robot(request: Request, registry: RegistryDep) -> Response:
    """The body is read here, not by FastAPI: a large one is decoded and validated in a child
    process (`service.api.upload_body`); `openapi_routes` documents it as an `UploadRequest`."""
    body = await request.body()
    content_type = request.headers.get("content-type")
    if len(body) <= INLINE_UPLOAD_BYTES:
        outcome = read_upload(body, content_type)
    else:
        settings = request.app.state.settings
        outcome = await run_in_threadpool(
            read_upload_isolated,
            body,
            content_type,
            registry.build_slots,
            settings.build_timeout_s,
            settings.build_cpu_s,
        )
    del body
    upload = upload_request(outcome)
    robot, created = await run_in_threadpool(
        registry.upload,
        urdf=upload.urdf,
        mjcf=upload.mjcf,
        root_joint=upload.root_joint,
        gravity=upload.gravity,
        name=upload.name,
        inertia_check=upload.inertia_check,
        locked_joints=upload.locked_joints,
        assets=upload.assets,
        xacro=upload.xacro,
        xacro_args=upload.xacro_args,
        repair=upload_repairs(registry),
    )
    return JSONAnswer(
        robot.info(),
        status_code=201 if created else 200,
        headers={"Location": f"/v1/robots/{robot.id}"},
    )


def openapi_routes() -> APIRouter:
    """Routes that only describe `upload_robot` in the OpenAPI document (never mounted)."""
    described = APIRouter(prefix="/v1/robots", tags=["robots"])

    @described.post("", **_UPLOAD)
    async def upload_robot(body: UploadRequest) -> None:
        raise NotImplementedError  # documentation only: the route above serves it

    return described


@router.post(
    "/{robot_id}/reduce",
    response_model=RobotInfo,
    status_code=201,
    responses={
        200: {"model": RobotInfo, "description": "the model was already stored"},
        401: {"model": Problem},
        404: {"model": Problem, "description": "robot_not_found"},
        422: {
            "model": Problem,
            "description": "validation_error (unknown "
            "joint, wrong value size), invalid_configuration (outside limits, "
            "non-unit quaternion), invalid_model (nothing left to move)",
        },
    },
    dependencies=[Depends(require_api_key)],
    summary="Store a reduced model of any robot, some joints locked: 201 new, 200 stored",
)
async def reduce_robot(robot_id: str, body: ReduceRequest, registry: RegistryDep) -> Response:
    """Lock `locked_joints` of robot `robot_id` (catalog or upload) at the given positions and
    store the reduced model under a new content-derived id (`r-` + 24 hex digits)."""
    robot, created = await run_in_threadpool(
        registry.reduce, robot_id, body.locked_joints, body.name
    )
    return JSONAnswer(
        robot.info(),
        status_code=201 if created else 200,
        headers={"Location": f"/v1/robots/{robot.id}"},
    )


@router.post(
    "/{robot_id}/variants",
    response_model=RobotInfo,
    status_code=201,
    responses={
        200: {"model": RobotInfo, "description": "the variant was already stored"},
        401: {"model": Problem},
        404: {"model": Problem, "description": "robot_not_found"},
        422: {
            "model": Problem,
            "description": "validation_error (a bad payload, "
            "named by its index; an unknown joint; no modification; a parent 32 variants "
            "deep, MAX_VARIANT_DEPTH), "
            "unknown_frame, invalid_configuration, invalid_model",
        },
    },
    dependencies=[Depends(require_api_key)],
    summary="Store a variant of any robot (payloads, locked joints, repaired inertias): 201 new, "
    "200 stored",
)
async def create_variant(robot_id: str, body: VariantRequest, registry: RegistryDep) -> Response:
    """Store robot `robot_id` (catalog, upload or variant) with the link inertials of `inertias`
    repaired, carrying `payloads`, then with `locked_joints` locked, under an id derived from the
    parent's id and the modifications (`v-` + 24 hex digits; `r-` for locked joints alone, as
    `reduce` gives). Its RobotInfo has `parent` and `modifications`; it survives a restart and the
    deletion of its parent."""
    parent = await served_robot(registry, robot_id)
    requested = [p.model_dump() for p in body.payloads or ()]
    placed = check_payloads(parent, requested) if requested else ()
    inertias = None
    if body.inertias is not None:
        selection, how = body.inertias.links, body.inertias.from_
        repairs = await run_in_threadpool(variant_repairs, registry, parent.id, selection, how)
        inertias = {"links": selection, "from": how, "repairs": repairs}
    robot, created = await run_in_threadpool(
        lambda: registry.variant(
            robot_id,
            payloads=placed,
            locked_joints=body.locked_joints,
            name=body.name,
            inertias=inertias,
        )
    )
    return JSONAnswer(
        robot.info(),
        status_code=201 if created else 200,
        headers={"Location": f"/v1/robots/{robot.id}"},
    )


@router.delete(
    "/{robot_id}",
    status_code=204,
    dependencies=[Depends(require_api_key)],
    responses={
        401: {"model": Problem},
        404: {"model": Problem},
        409: {"model": Problem, "description": "catalog_robot"},
    },
    summary="Delete an uploaded model",
)
async def delete_robot(robot_id: str, registry: RegistryDep) -> Response:
    await run_in_threadpool(registry.delete, robot_id)  # it sweeps unnamed asset files
    return Response(status_code=204)
