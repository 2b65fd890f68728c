"""The robot list in pages: GET /v1/robots answers at most `limit` robots and an opaque cursor
where the next page starts (null after the last page).

The list's order is the catalog's robots in catalog order, then the stored models by id. A
cursor holds the position after its page's last robot (a catalog index, or the last stored id
listed), so models stored or deleted between two pages never make a later page repeat a robot
or skip one that is still stored (a model stored meanwhile under an id before the cursor's
appears on the next walk from the first page). The default page holds the whole catalog
(`DEFAULT_PAGE` is over its size, a test checks it), so a client that never follows a cursor
still sees every catalog robot.
"""

from __future__ import annotations

import base64
import binascii
from bisect import bisect_right
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from service.errors import InvalidInput

DEFAULT_PAGE = 200  # robots per page when `limit` is not given
MAX_PAGE = 1000  # the largest `limit`
_CATALOG, _STORED = "c", "s"  # the two parts of the list, as a cursor names them


@dataclass(frozen=True)
class Page:
    """At most `limit` robot summaries, and the cursor of the next page (None: the last)."""

    robots: list[dict[str, Any]]
    next_cursor: str | None


def page(
    catalog: Sequence[dict[str, Any]],
    stored_ids: Sequence[str],
    summary: Callable[[str], dict[str, Any] | None],
    limit: int,
    cursor: str | None,
) -> Page:
    """The page of the list (`catalog` summaries in order, then those of `stored_ids`, sorted,
    by `summary(id)`; None skips an unreadable record) that starts at `cursor` (None: the
    first page): at most `limit` robots. Only the records listed on the page are read."""
    start, after = 0, None
    if cursor is not None:
        part, position = _decode(cursor)
        if part == _CATALOG:
            start = min(int(position), len(catalog))
        else:
            start, after = len(catalog), position
    robots = list(catalog[start : start + limit])
    if start + len(robots) < len(catalog):
        return Page(robots, _encode(_CATALOG, str(start + len(robots))))
    i = 0 if after is None else bisect_right(stored_ids, after)
    last = after or ""
    while len(robots) < limit and i < len(stored_ids):
        last = stored_ids[i]
        found = summary(last)
        if found is not None:
            robots.append(found)
        i += 1
    return Page(robots, _encode(_STORED, last) if i < len(stored_ids) else None)


def _encode(part: str, position: str) -> str:
    raw = f"{part}:{position}".encode()
    return base64.urlsafe_b64encode(raw).rstrip(b"=").decode("ascii")


def _decode(cursor: str) -> tuple[str, str]:
    """(part, position) of a cursor `_encode` made; `InvalidInput` for anything else."""
    try:
        text = base64.urlsafe_b64decode(cursor + "=" * (-len(cursor) % 4)).decode("ascii")
    except (binascii.Error, UnicodeDecodeError, ValueError):
        text = ""
    part, _, position = text.partition(":")
    if (part == _CATALOG and position.isdigit()) or (part == _STORED and len(position) <= 64):
        return part, position
    raise InvalidInput(
        "cursor is not a next_cursor this service gave: pass the `next_cursor` of the previous "
        "page unchanged, or leave cursor out for the first page"
    )
