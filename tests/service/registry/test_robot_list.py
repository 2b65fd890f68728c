"""GET /v1/robots reads each stored record once (records never change under their id), and
still sees what other replicas sharing the directory upload and delete."""

from __future__ import annotations

from tests.helpers import planar_arm_urdf


def _upload(client, m1: float) -> str:
    r = client.post("/v1/robots", json={"urdf": planar_arm_urdf(1.0, 0.8, m1, 1.0)})
    assert r.status_code == 201, r.text
    return r.json()["id"]


def test_listing_reads_each_record_once_and_follows_the_directory(
    small_app_factory, tmp_path, monkeypatch
) -> None:
    one = small_app_factory(tmp_path, catalog="ur5")
    other_replica = small_app_factory(tmp_path, catalog="ur5")
    first, second = _upload(one, 2.0), _upload(other_replica, 3.0)

    store = one.app.state.registry.store
    reads: list[str] = []
    real_read = store.read
    monkeypatch.setattr(
        store, "read", lambda model_id: reads.append(model_id) or real_read(model_id)
    )

    def listed() -> set[str]:
        r = one.get("/v1/robots")
        assert r.status_code == 200
        return {robot["id"] for robot in r.json()["robots"]}

    assert {"ur5", first, second} <= listed()
    assert listed() == {"ur5", first, second}
    assert sorted(reads) == sorted({first, second})  # the second listing read nothing

    assert other_replica.delete(f"/v1/robots/{second}").status_code == 204
    third = _upload(other_replica, 4.0)
    assert listed() == {"ur5", first, third}
    assert reads.count(second) == 1 and reads.count(third) == 1


def test_the_list_comes_in_pages_that_follow_next_cursor(small_app_factory, tmp_path) -> None:
    api = small_app_factory(tmp_path, catalog="ur5,planar_arm")
    made = []
    for i in range(1, 10):
        body = {"payloads": [{"frame": "link2", "mass": 0.1 * i}]}
        r = api.post("/v1/robots/planar_arm/variants", json=body)
        assert r.status_code == 201, r.text
        made.append(r.json()["id"])
    catalog = list(api.app.state.registry.catalog)  # in the catalog's order
    assert sorted(catalog) == ["planar_arm", "ur5"]
    whole = [*catalog, *sorted(made)]

    r = api.get("/v1/robots")  # a client that knows nothing of pages
    assert r.status_code == 200
    assert [x["id"] for x in r.json()["robots"]] == whole and r.json()["next_cursor"] is None
    walked, cursor, pages = [], None, 0
    while True:
        params = {"limit": 4} | ({"cursor": cursor} if cursor else {})
        r = api.get("/v1/robots", params=params)
        assert r.status_code == 200, r.text
        answer = r.json()
        assert len(answer["robots"]) <= 4 and answer["unavailable"] == {}
        walked += [x["id"] for x in answer["robots"]]
        pages += 1
        cursor = answer["next_cursor"]
        if cursor is None:
            break
    assert walked == whole and pages == 3


def test_bad_limits_and_cursors_are_a_422_naming_them(small_app_factory, tmp_path) -> None:
    api = small_app_factory(tmp_path, catalog="planar_arm")
    for params, named in (
        ({"limit": 0}, "limit"),
        ({"limit": 1001}, "limit"),
        ({"limit": "ten"}, "limit"),
        ({"cursor": "not-a-cursor"}, "cursor"),
        ({"cursor": "c" * 201}, "cursor"),
    ):
        r = api.get("/v1/robots", params=params)
        assert r.status_code == 422, (params, r.text)
        assert r.headers["content-type"].startswith("application/problem+json")
        assert r.json()["code"] == "validation_error" and named in r.json()["detail"], r.text
