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
