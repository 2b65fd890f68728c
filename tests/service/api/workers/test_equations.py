"""The derivation in a child process with a time limit (a child starved of CPU or killed from
outside is the machine's condition, 503, not the model's), and the cache: per robot, with
refusals for cost remembered per content and the machine's conditions not remembered."""

from __future__ import annotations

import asyncio
import os
import signal
import time

import orjson
import pinocchio as pin
import pytest

from service.api.workers import equations_cache as cache_module
from service.api.workers.equations import TooCostly, derive_isolated
from service.api.workers.equations_cache import EquationsCache
from service.dynamics.equations import derive_equations, equations_answer
from service.errors import Overloaded, UnsupportedModel
from service.registry.build_slots import BuildSlots
from service.registry.robot import Robot
from tests.helpers import planar_arm_urdf, skewed_arm_urdf, unless_starved
from tests.service.processes.from_outside import raised_when_its_child


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
    model = pin.buildModelFromXML(skewed_arm_urdf(6))  # seconds of CPU
    with pytest.raises(TooCostly, match=r"time limit of 0\.3 s"):
        unless_starved(lambda: derive_isolated(model, time_limit_s=0.3))


def test_a_starved_derivation_is_overloaded_not_too_costly():
    """A child stopped for its whole time (SIGSTOP: no CPU at all) says nothing of the
    model's cost."""
    model = pin.buildModelFromXML(skewed_arm_urdf(6))
    raised = raised_when_its_child(
        lambda: derive_isolated(model, time_limit_s=1.0),
        lambda pid: os.kill(pid, signal.SIGSTOP),
    )
    assert isinstance(raised, Overloaded) and "CPU time" in raised.detail, raised


def test_a_derivation_killed_from_outside_is_overloaded():
    """SIGKILL from outside (the kernel's OOM killer) is the machine's condition."""
    model = pin.buildModelFromXML(skewed_arm_urdf(6))
    raised = raised_when_its_child(
        lambda: derive_isolated(model, time_limit_s=60.0),
        lambda pid: os.kill(pid, signal.SIGKILL),
    )
    assert isinstance(raised, Overloaded), raised
    assert "killed by signal 9 (SIGKILL)" in raised.detail and "out of memory" in raised.detail


def test_out_of_scope_child_answer_is_unsupported():
    model = pin.buildModelFromXML(skewed_arm_urdf(2), pin.JointModelFreeFlyer())
    with pytest.raises(UnsupportedModel, match="free-flyer root"):
        derive_isolated(model, time_limit_s=60)


@pytest.fixture
def counted(monkeypatch):
    """Count the derivations the cache starts (the real child process still runs)."""
    calls: list[str] = []

    def counting(model, time_limit_s, memory_mb, printing=None):
        calls.append(model.name)
        time.sleep(0.2)  # long enough for concurrent callers to find it pending
        return derive_isolated(model, time_limit_s, memory_mb, printing)

    monkeypatch.setattr(cache_module, "derive_isolated", counting)
    return calls


def _answer(cache: EquationsCache, robot: Robot) -> bytes:
    return asyncio.run(cache.answer(robot))


def test_cache_memory_disk_and_single_flight(tmp_path, counted):
    slots = BuildSlots(2, 10)
    robot = _robot(planar_arm_urdf(1.0, 0.7, 2.0, 1.5), "u-arm")
    cache = EquationsCache(tmp_path, 30, slots)

    async def three() -> list[bytes]:
        return list(await asyncio.gather(*(cache.answer(robot) for _ in range(3))))

    answers = asyncio.run(three())
    assert len(counted) == 1 and len(set(answers)) == 1 and len(answers) == 3
    assert orjson.loads(answers[0])["mass_matrix"]["expressions"][1][1] == "0.735"
    assert _answer(cache, robot) == answers[0]  # from memory (timed in bench/equations.py)
    assert (
        tmp_path / "equations" / "v3" / "u-arm" / "numeric-6-1e-09.json"
    ).read_bytes() == answers[0]
    # another process (a restart, a replica) sharing the data directory: no derivation
    again = EquationsCache(tmp_path, 30, slots)
    assert _answer(again, robot) == answers[0] and len(counted) == 1
    # catalog robots are kept in memory only
    catalog_robot = _robot(planar_arm_urdf(1.0, 0.7, 2.0, 1.5), "planar", source="catalog")
    _answer(again, catalog_robot)
    assert not (tmp_path / "equations" / "v3" / "planar").exists()


def test_cache_refuses_out_of_scope_models_without_a_child(tmp_path, counted):
    urdf = planar_arm_urdf(1.0, 0.7, 2.0, 1.5).replace('type="revolute"', 'type="continuous"')
    cache = EquationsCache(tmp_path, 30, BuildSlots(1, 10))
    robot = _robot(urdf, "u-wheel")
    for _ in range(2):
        with pytest.raises(UnsupportedModel, match="'shoulder' is continuous"):
            _answer(cache, robot)
    assert counted == []


def _renamed(urdf: str) -> str:
    """The same robot's description with other link and joint names (the same numbers)."""
    for name in ("base", "link1", "link2", "shoulder", "elbow"):
        urdf = urdf.replace(f'"{name}"', f'"other_{name}"')
    return urdf


def test_a_refusal_for_cost_is_remembered_for_every_robot_with_the_same_numbers(
    tmp_path, monkeypatch
):
    calls: list[str] = []

    def too_costly(model, time_limit_s, memory_mb, printing=None):
        calls.append(model.name)
        raise TooCostly(f"the derivation of the equations did not finish within {time_limit_s}")

    monkeypatch.setattr(cache_module, "derive_isolated", too_costly)
    cache = EquationsCache(tmp_path, 30, BuildSlots(1, 10))
    urdf = planar_arm_urdf(1.0, 0.7, 2.0, 1.5)
    first = _robot(urdf, "u-first")
    same_numbers = _robot(_renamed(urdf), "u-same-numbers")
    assert same_numbers.model.names[1] != first.model.names[1]
    other_numbers = _robot(planar_arm_urdf(1.0, 0.8, 2.0, 1.5), "u-other-numbers")
    refusals = []
    for robot in (first, first, same_numbers):
        with pytest.raises(UnsupportedModel) as refused:
            _answer(cache, robot)
        refusals.append(refused.value.detail)
    assert len(calls) == 1 and len(set(refusals)) == 1  # the same 422, derived once
    with pytest.raises(UnsupportedModel):
        _answer(cache, other_numbers)  # other numbers: derived (refused again, here)
    assert len(calls) == 2


def test_a_derivation_the_machine_starved_is_not_remembered(tmp_path, monkeypatch):
    outcomes = [Overloaded("the derivation got only 0.1 s of CPU time in its 30 s")]

    def starved_once(model, time_limit_s, memory_mb, printing=None):
        if outcomes:
            raise outcomes.pop()
        return derive_isolated(model, time_limit_s, memory_mb, printing)

    monkeypatch.setattr(cache_module, "derive_isolated", starved_once)
    cache = EquationsCache(tmp_path, 30, BuildSlots(1, 10))
    robot = _robot(planar_arm_urdf(1.0, 0.7, 2.0, 1.5), "u-starved")
    with pytest.raises(Overloaded):
        _answer(cache, robot)
    answer = orjson.loads(_answer(cache, robot))  # derived this time
    assert answer["mass_matrix"]["expressions"][1][1] == "0.735"
