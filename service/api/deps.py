"""Request dependencies shared by the routers: the registry, settings and API-key checks."""

from __future__ import annotations

import hmac
from typing import Annotated

from fastapi import Depends, Request

from service.errors import Unauthorized
from service.registry import Registry
from service.settings import Settings


async def get_registry(request: Request) -> Registry:
    return request.app.state.registry  # type: ignore[no-any-return]


async def get_settings(request: Request) -> Settings:
    return request.app.state.settings  # type: ignore[no-any-return]


async def require_api_key(request: Request) -> None:
    """Where `ROBODYN_API_KEYS` is set, demand `Authorization: Bearer <key>` (constant time)."""
    keys: list[bytes] = request.app.state.api_keys
    if not keys:
        return
    header = request.headers.get("authorization", "")
    scheme, _, token = header.partition(" ")
    given = token.strip().encode()
    ok = False
    for key in keys:  # compare with every key so timing does not reveal which one matched
        ok |= hmac.compare_digest(given, key)
    if scheme.lower() != "bearer" or not ok:
        raise Unauthorized("this operation needs an API key: send 'Authorization: Bearer <key>'")


RegistryDep = Annotated[Registry, Depends(get_registry)]
