"""Pages of the robot list: walking the pages with any `limit` gives the whole list once, in
order (the catalog, then stored models by id), reading only the records listed; models stored
or deleted between two pages are never repeated nor make a listed model disappear; a cursor
this service did not give is a 422; the default page holds the whole catalog."""

from __future__ import annotations

import base64
import random
import tomllib
from pathlib import Path

import pytest

from service.errors import InvalidInput
from service.registry.robot_pages import DEFAULT_PAGE, MAX_PAGE, page

CATALOG = [{"id": f"robot{i}"} for i in range(5)]


def stored(ids: list[str], unreadable: set[str] = frozenset(), reads: list[str] | None = None):
    def summary(model_id: str):
        if reads is not None:
            reads.append(model_id)
        return None if model_id in unreadable else {"id": model_id}

    return sorted(ids), summary


def walk(catalog, ids, summary, limit) -> list[str]:
    out: list[str] = []
    cursor = None
    while True:
        listed = page(catalog, ids, summary, limit, cursor)
        assert len(listed.robots) <= limit
        out += [r["id"] for r in listed.robots]
        if listed.next_cursor is None:
            return out
        cursor = listed.next_cursor


def test_every_limit_walks_the_whole_list_once_in_order() -> None:
    rng = random.Random(3)
    ids = [f"v-{rng.getrandbits(48):012x}" for _ in range(23)]
    unreadable = set(ids[::7])
    readable = sorted(set(ids) - unreadable)
    for limit in (1, 2, 3, 5, 6, 7, 27, 28, 40):
        reads: list[str] = []
        sorted_ids, summary = stored(ids, unreadable, reads)
        assert walk(CATALOG, sorted_ids, summary, limit) == [c["id"] for c in CATALOG] + readable
        assert sorted(reads) == sorted(ids)  # each record read once over the walk
    # nothing stored: the catalog alone, and the last page says so
    only = page(CATALOG, [], stored([])[1], 5, None)
    assert [r["id"] for r in only.robots] == [c["id"] for c in CATALOG]
    assert only.next_cursor is None


def test_a_page_reads_only_the_records_it_lists() -> None:
    reads: list[str] = []
    ids, summary = stored([f"u-{i:03d}" for i in range(50)], reads=reads)
    first = page(CATALOG, ids, summary, 8, None)
    assert reads == ids[:3] and first.next_cursor is not None
    reads.clear()
    second = page(CATALOG, ids, summary, 8, first.next_cursor)
    assert reads == ids[3:11] and [r["id"] for r in second.robots] == ids[3:11]


def test_models_stored_or_deleted_between_pages() -> None:
    ids = [f"u-{i:03d}" for i in range(0, 40, 2)]
    _, summary = stored(ids)
    first = page(CATALOG, sorted(ids), summary, 10, None)
    seen = [r["id"] for r in first.robots]
    assert seen[-1] == "u-008"
    # another replica stores u-001 (before the cursor) and u-031, and deletes u-010 and u-020
    now = sorted({*ids, "u-001", "u-031"} - {"u-010", "u-020"})
    cursor, rest = first.next_cursor, []
    while cursor is not None:
        listed = page(CATALOG, now, summary, 4, cursor)
        rest += [r["id"] for r in listed.robots]
        cursor = listed.next_cursor
    assert rest == [i for i in now if i > "u-008"]  # each once, u-031 included
    assert not set(seen) & set(rest)


def test_a_cursor_this_service_did_not_give_is_refused() -> None:
    ids, summary = stored(["u-1", "u-2"])

    def b64(text: str) -> str:
        return base64.urlsafe_b64encode(text.encode()).decode().rstrip("=")

    for cursor in ("", "garbage!", "not base64 at all", b64("x:1"), b64("c:-1"), b64("c:one")):
        with pytest.raises(InvalidInput, match="cursor is not a next_cursor"):
            page(CATALOG, ids, summary, 5, cursor)
    assert [r["id"] for r in page(CATALOG, ids, summary, 5, b64("s:u-1")).robots] == ["u-2"]


def test_the_default_page_holds_the_whole_catalog() -> None:
    catalog = tomllib.loads((Path(__file__).parents[3] / "robots" / "catalog.toml").read_text())
    assert len(catalog["robots"]) <= DEFAULT_PAGE <= MAX_PAGE
