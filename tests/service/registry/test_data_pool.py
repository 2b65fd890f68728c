"""The process-wide budget of idle Pinocchio Datas: bounded, least recently used dropped first,
released when a robot goes away; answers are unchanged whether a Data was kept or not."""

from __future__ import annotations

import gc

import numpy as np
import pinocchio as pin
import pytest

from service.registry import data_pool
from service.registry.data_pool import Budget, Pool, data_bytes
from service.registry.robot import Robot


def _pool(budget: Budget, size: int) -> Pool:
    pool = Pool(budget, 1)
    pool.size = size
    return pool


def test_idle_datas_stay_within_the_budget_and_the_least_recent_go_first() -> None:
    budget = Budget(100)
    a, b, c = _pool(budget, 40), _pool(budget, 40), _pool(budget, 40)
    a.give("a1")
    b.give("b1")
    assert budget.idle_bytes == 80
    c.give("c1")  # needs 40 more: a, the least recently used, gives its Data up
    assert budget.idle_bytes == 80 and not a.idle and list(b.idle) == ["b1"]
    assert a.take() is None and c.take() == "c1" and budget.idle_bytes == 40
    b.give("b2")
    b.give("b3")  # 120 > 100 and no other robot holds idle Datas: b3 itself is dropped
    assert list(b.idle) == ["b1", "b2"] and budget.idle_bytes == 80


def test_a_data_bigger_than_the_budget_is_never_kept() -> None:
    budget = Budget(100)
    small, big = _pool(budget, 10), _pool(budget, 101)
    small.give("s")
    big.give("B")
    assert not big.idle and list(small.idle) == ["s"] and budget.idle_bytes == 10


def test_model_pools_count_and_are_dropped_like_datas() -> None:
    budget = Budget(100)
    a, b = _pool(budget, 10), _pool(budget, 10)
    budget.keep_model_pool(a, "mpA", 60)
    budget.keep_model_pool(a, "mpA", 60)  # the same one again: counted once
    assert a.model_pool == "mpA" and budget.idle_bytes == 60
    budget.keep_model_pool(b, "mpB", 60)  # a's goes to make room
    assert a.model_pool is None and b.model_pool == "mpB" and budget.idle_bytes == 60
    b.close()
    assert budget.idle_bytes == 0 and b.model_pool is None


def _chain(n: int) -> Robot:
    model = pin.Model()
    parent = 0
    for i in range(n):
        parent = model.addJoint(
            parent, pin.JointModelRX(), pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.1])), f"j{i}"
        )
        model.appendBodyToJoint(
            parent, pin.Inertia.FromBox(1.0, 0.05, 0.05, 0.1), pin.SE3.Identity()
        )
    return Robot(id=f"chain{n}", name="chain", source="upload", root_joint="fixed", model=model)


@pytest.fixture
def small_budget(monkeypatch: pytest.MonkeyPatch) -> Budget:
    budget = Budget(data_bytes(20) + data_bytes(8))
    monkeypatch.setattr(data_pool, "BUDGET", budget)
    return budget


def test_robots_share_the_budget_and_answers_do_not_change(small_budget: Budget) -> None:
    first, second = _chain(20), _chain(12)
    q = np.linspace(-1, 1, 20)
    with first.data() as data:
        want = pin.crba(first.model, data, q).copy()
    assert small_budget.idle_bytes == data_bytes(20)
    with second.data():
        pass  # 20 + 12 does not fit: first's idle Data is dropped, second's kept
    assert small_budget.idle_bytes == data_bytes(12)
    with first.data() as data:  # created anew
        np.testing.assert_array_equal(pin.crba(first.model, data, q), want)
    assert small_budget.idle_bytes <= small_budget.limit_bytes


def test_a_robot_that_is_gone_gives_its_datas_back(small_budget: Budget) -> None:
    robot = _chain(8)
    with robot.data():
        pass
    assert small_budget.idle_bytes == data_bytes(8)
    del robot
    gc.collect()
    assert small_budget.idle_bytes == 0


def test_the_setting_sets_the_budget(tmp_path) -> None:
    from service.main import create_app
    from service.settings import Settings

    before = data_pool.BUDGET.limit_bytes
    try:
        create_app(Settings(data_dir=tmp_path, data_pool_mb=7, catalog="ur5"))
        assert data_pool.BUDGET.limit_bytes == 7 * 1024 * 1024
    finally:
        data_pool.BUDGET.limit_bytes = before
