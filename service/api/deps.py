"""Request dependencies shared by the routers: the registry and the API-key checks.

API keys (`ROBODYN_API_KEYS`, comma-separated) guard routes in two scopes:

- `require_api_key`: uploads, reductions and deletions, whenever keys are set;
- `require_api_key_for_all`: every other /v1 route (reads and compute), only when
  `ROBODYN_API_KEYS_SCOPE=all`. `service.main` attaches it to the robots and dynamics routers.

Health, metrics and the docs are never guarded. Keys are compared in constant time against every
configured key, and never logged or echoed.
"""

from __future__ import annotations

import hmac
from typing import Annotated

from fastapi import Depends
from starlette.concurrency import run_in_threadpool
from starlette.requests import HTTPConnection

from service.errors import Unauthorized
from service.registry import Registry, Robot
from service.settings import Settings

# Dependencies are coroutines: FastAPI runs a plain `def` dependency in the thread pool, a hop
# that cost more than the whole computation on the hot routes.


async def get_registry(request: HTTPConnection) -> Registry:
    return request.app.state.registry  # type: ignore[no-any-return]


async def served_robot(registry: Registry, robot_id: str) -> Robot:
    """`registry.get(robot_id)`, in a worker thread when it would build a stored model from
    its record (the first request for it since start-up): the event loop never waits for a
    model to be built."""
    if registry.built(robot_id):
        return registry.get(robot_id)
    return await run_in_threadpool(registry.get, robot_id)


def _check_key(connection: HTTPConnection, what: str) -> None:
    keys: list[bytes] = connection.app.state.api_keys
    if not keys:
        return
    header = connection.headers.get("authorization", "")
    scheme, _, token = header.partition(" ")
    given = token.strip().encode("utf-8", "replace")
    ok = False
    for key in keys:  # compare with every key so timing does not reveal which one matched
        ok |= hmac.compare_digest(given, key)
    if scheme.lower() != "bearer" or not ok:
        raise Unauthorized(f"{what} needs an API key: send 'Authorization: Bearer <key>'")


async def require_api_key(connection: HTTPConnection) -> None:
    """Where `ROBODYN_API_KEYS` is set, demand `Authorization: Bearer <key>` (constant time)."""
    check_api_key(connection)


def check_api_key(connection: HTTPConnection) -> None:
    """`require_api_key` as a plain call (`service.api.middleware.api_keys`)."""
    _check_key(connection, "this operation")


async def require_api_key_for_all(connection: HTTPConnection) -> None:
    """With `ROBODYN_API_KEYS_SCOPE=all`, demand a key on reads and compute too."""
    check_api_key_for_all(connection)


def check_api_key_for_all(connection: HTTPConnection) -> None:
    """`require_api_key_for_all` as a plain call (the lean dynamics and stream routes)."""
    settings: Settings = connection.app.state.settings
    if settings.api_keys_scope == "all":
        _check_key(connection, "this server (ROBODYN_API_KEYS_SCOPE=all)")


RegistryDep = Annotated[Registry, Depends(get_registry)]
