"""The derivation in a child process with a time limit, and the per-robot cache."""

from __future__ import annotations

import threading
import time

import orjson
import pinocchio as pin
import pytest

from service.dynamics.equations import cache as cache_module
from service.dynamics.equations import derive_equations, equations_answer
from service.dynamics.equations.cache import EquationsCache
from service.dynamics.equations.isolated import GRACE_S, derive_isolated
from service.errors import UnsupportedModel
from service.registry.build_slots import BuildSlots
from service.registry.robot import Robot
from tests.helpers import planar_arm_urdf, skewed_arm_urdf, unless_starved


def _robot(urdf: str, robot_id: str, source: str = "upload") -> Robot:
    return Robot(
        id=robot_id,
        name=robot_id,
        source=source,
        root_joint="fixed",
        model=pin.buildModelFromXML(urdf),
    )


def test_child_answer_equals_in_process_derivation():
    model = pin.buildModelFromXML(skewed_arm_urdf(3))
    body = derive_isolated(model, time_limit_s=60)
    assert orjson.loads(body) == orjson.loads(
        orjson.dumps(equations_answer(derive_equations(model)))
    )


def test_derivation_past_its_time_limit_is_unsupported():
    model = pin.buildModelFromXML(skewed_arm_urdf(5))  # about 3 s of CPU
    started = time.monotonic()
    with pytest.raises(UnsupportedModel, match=r"time limit of 0\.3 s"):
        unless_starved(lambda: derive_isolated(model, time_limit_s=0.3))
    # A try ends within the time limit and GRACE_S (2 s) of its start, and there are at most
    # three (a starved child is tried again): a bound against a parent that waits for the
    # whole derivation (~3 s of CPU, far longer on a loaded machine).
    assert time.monotonic() - started < 3 * (0.3 + GRACE_S) + 5


def test_out_of_scope_child_answer_is_unsupported():
    model = pin.buildModelFromXML(skewed_arm_urdf(2), pin.JointModelFreeFlyer())
    with pytest.raises(UnsupportedModel, match="free-flyer root"):
        derive_isolated(model, time_limit_s=60)


@pytest.fixture
def counted(monkeypatch):
    """Count the derivations the cache starts (the real child process still runs)."""
    calls: list[str] = []

    def counting(model, time_limit_s, memory_mb):
        calls.append(model.name)
        time.sleep(0.2)  # long enough for concurrent callers to find it pending
        return derive_isolated(model, time_limit_s, memory_mb)

    monkeypatch.setattr(cache_module, "derive_isolated", counting)
    return calls


def test_cache_memory_disk_and_single_flight(tmp_path, counted):
    slots = BuildSlots(2, 10)
    robot = _robot(planar_arm_urdf(1.0, 0.7, 2.0, 1.5), "u-arm")
    cache = EquationsCache(tmp_path, 30, slots)
    answers: list[bytes] = []
    threads = [
        threading.Thread(target=lambda: answers.append(cache.answer(robot))) for _ in range(3)
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(counted) == 1 and len(set(answers)) == 1 and len(answers) == 3
    assert orjson.loads(answers[0])["mass_matrix"]["expressions"][1][1] == "0.735"
    assert cache.answer(robot) == answers[0]  # from memory (timed in bench/equations.py)
    assert (tmp_path / "equations" / "v1" / "u-arm.json").read_bytes() == answers[0]
    # another process (a restart, a replica) sharing the data directory: no derivation
    again = EquationsCache(tmp_path, 30, slots)
    assert again.answer(robot) == answers[0] and len(counted) == 1
    # catalog robots are kept in memory only
    catalog_robot = _robot(planar_arm_urdf(1.0, 0.7, 2.0, 1.5), "planar", source="catalog")
    again.answer(catalog_robot)
    assert not (tmp_path / "equations" / "v1" / "planar.json").exists()


def test_cache_refuses_out_of_scope_models_without_a_child(tmp_path, counted):
    urdf = planar_arm_urdf(1.0, 0.7, 2.0, 1.5).replace('type="revolute"', 'type="continuous"')
    cache = EquationsCache(tmp_path, 30, BuildSlots(1, 10))
    robot = _robot(urdf, "u-wheel")
    for _ in range(2):
        with pytest.raises(UnsupportedModel, match="'shoulder' is continuous"):
            cache.answer(robot)
    assert counted == []
