"""Variant lineages: a variant's record holds its lineage flat (the root and each variant
between), records in the nested form load (flattened on read), variants deeper than
MAX_VARIANT_DEPTH are refused with a 422 naming the cap, and start-up builds no stored model.

`fixtures/nested_store/models/` holds records in the nested form (each variant's
`base.record` holding its parent's whole record), written by the registry of commit 269a15b:
  - the planar arm (`planar_arm_urdf(0.7, 0.5, 1.5, 0.8)`, an upload) → holding 2 kg at the
    tip of link2 → with identified friction → holding 1 kg at the tip of link1 → the elbow
    locked at 0.3 rad (a reduced model);
  - ur5 → holding TOOL at tool0 → wrist_3_joint locked at 0.1 rad.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from service.dynamics.payloads import check_payloads
from service.errors import InvalidInput
from service.registry import Registry
from service.registry.lineage import MAX_VARIANT_DEPTH
from service.registry.payloads import PlacedPayload
from service.registry.records import check_record
from service.registry.store import ModelStore
from service.registry.variants import Fitted, variant_id
from tests.helpers import planar_arm_closed_form

NESTED = Path(__file__).parent / "fixtures" / "nested_store"
ARM = "u-b3451ce632617f2e6d06e361"
ARM_CHAIN = [  # each the parent of the next
    "v-97f67741bad3b4315e8abf36",  # + 2 kg at link2's tip
    "v-4dca734c0bac54191f87cfea",  # + friction
    "v-94a3cbb3560587a88c25fed7",  # + 1 kg at link1's tip
    "r-ad7d0f67b59e3d59efe88c7d",  # elbow locked at 0.3
]
UR5_CHAIN = ["v-472834742443137803e9d95f", "r-7ac70a5bb1cfafb5ca084911"]
FRICTION_KEYS = ("joint", "coulomb", "viscous", "offset")
FRICTION = (("shoulder", 0.25, 0.5, 0.0), ("elbow", 0.125, 0.25, -0.0625))
TOOL = {
    "frame": "tool0",
    "mass": 3.0,
    "center_of_mass": [0.0, 0.0, 0.05],
    "inertia": [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.005]],
}
L1, L2, M1, M2 = 0.7, 0.5, 1.5, 0.8


def registry(data_dir: Path, catalog: list[str] | None = None) -> Registry:
    out = Registry(data_dir, catalog or ["ur5"])
    out.load()
    return out


def nested_store(tmp_path: Path) -> Path:
    data = tmp_path / "data"
    shutil.copytree(NESTED, data)
    return data


def mass_matrix(robot, q) -> np.ndarray:
    return pin.crba(robot.model, robot.model.createData(), np.asarray(q, dtype=float))


def arm_mass_matrix(m1: float, m2: float, q) -> np.ndarray:
    """The point-mass arm's M, hand-derived (tests.helpers)."""
    return planar_arm_closed_form(L1, L2, m1, m2, np.asarray(q), np.zeros(2))[0]


def tip_payload(link: str, mass: float) -> list[dict]:
    """A point mass at the tip of `link` (where the arm's own point mass is)."""
    return [{"frame": link, "mass": mass, "center_of_mass": [L1 if link == "link1" else L2, 0, 0]}]


def test_records_in_the_nested_form_load_and_rebuild(tmp_path) -> None:
    reg = registry(nested_store(tmp_path))
    q = np.array([0.4, -0.9])
    v1, v2, v3, r4 = (reg.get(i) for i in ARM_CHAIN)
    np.testing.assert_allclose(mass_matrix(v1, q), arm_mass_matrix(M1, M2 + 2, q), rtol=1e-12)
    np.testing.assert_allclose(mass_matrix(v2, q), arm_mass_matrix(M1, M2 + 2, q), rtol=1e-12)
    np.testing.assert_allclose(mass_matrix(v3, q), arm_mass_matrix(M1 + 1, M2 + 2, q), rtol=1e-12)
    locked = arm_mass_matrix(M1 + 1, M2 + 2, [q[0], 0.3])[:1, :1]
    np.testing.assert_allclose(mass_matrix(r4, q[:1]), locked, rtol=1e-12)
    # friction follows the joints by name down the lineage (the elbow is locked away in r4)
    want = [dict(zip(FRICTION_KEYS, row, strict=True)) for row in FRICTION]
    assert v2.info()["friction"] == v3.info()["friction"] == want
    assert r4.info()["friction"] == want[:1]
    assert [reg.get(i).info()["parent"] for i in ARM_CHAIN] == [ARM, *ARM_CHAIN[:-1]]
    assert v1.name == "arm holding 2 kg" and v2.name == "arm with friction"

    # read flat: the root's record and one step per variant between, root first
    record = reg.store.read(ARM_CHAIN[-1])
    assert record is not None and record["base"]["id"] == ARM
    assert record["base"]["record"]["format"] == "urdf"
    assert [s["id"] for s in record["steps"]] == ARM_CHAIN[:-1]
    listed = {s["id"] for s in reg.summaries()}
    assert listed == {"ur5", ARM, *ARM_CHAIN, *UR5_CHAIN}


def test_nested_records_get_the_ids_and_answers_of_the_same_variants_made_anew(tmp_path) -> None:
    """The ur5 chain of the fixture against the same requests to a registry on an empty
    store: the same ids, the same RobotInfo, the same M."""
    old = registry(nested_store(tmp_path))
    new = registry(tmp_path / "fresh")
    made, _ = new.variant("ur5", payloads=check_payloads(new.get("ur5"), [TOOL]))
    reduced, _ = new.reduce(made.id, {"wrist_3_joint": 0.1})
    assert [made.id, reduced.id] == UR5_CHAIN
    q = np.array([0.2, -1.1, 1.3, -0.4, 0.6])
    for robot in (made, reduced):
        stored = old.get(robot.id)
        assert stored.info() == robot.info()
    np.testing.assert_array_equal(mass_matrix(old.get(reduced.id), q), mass_matrix(reduced, q))
    # the new record is flat: its steps are the variants between ur5 and its parent
    record = new.store.read(reduced.id)
    assert record is not None and record["base"] == {"source": "catalog", "id": "ur5"}
    assert [s["id"] for s in record["steps"]] == [made.id]


def test_a_variant_of_a_nested_record_is_flat_and_outlives_its_ancestors(tmp_path) -> None:
    data = nested_store(tmp_path)
    reg = registry(data)
    parent = reg.get(ARM_CHAIN[2])  # 1 kg at link1, 2 kg at link2, friction
    child, created = reg.variant(
        parent.id, payloads=check_payloads(parent, tip_payload("link2", 1))
    )
    assert created
    record = json.loads((data / "models" / f"{child.id}.json").read_text())
    assert record["base"]["id"] == ARM and "record" not in record["base"]["record"].get("base", {})
    assert [s["id"] for s in record["steps"]] == ARM_CHAIN[:3]
    for ancestor in (ARM, *ARM_CHAIN):
        reg.delete(ancestor)
    q = np.array([-0.3, 1.2])
    want = arm_mass_matrix(M1 + 1, M2 + 3, q)
    np.testing.assert_allclose(mass_matrix(reg.get(child.id), q), want, rtol=1e-12)
    restarted = registry(data)
    rebuilt = restarted.get(child.id)
    np.testing.assert_allclose(mass_matrix(rebuilt, q), want, rtol=1e-12)
    assert rebuilt.info()["friction"][0]["coulomb"] == FRICTION[0][1]
    assert {s["id"] for s in restarted.summaries()} == {"ur5", child.id, *UR5_CHAIN}


def _nested_chain(data: Path, levels: int, mass: float) -> str:
    """Write, in the nested form, a chain of `levels` variants of the fixture's arm, each
    adding a point mass `mass` at link2's tip: only the deepest record is stored. Its id."""
    root = json.loads((NESTED / "models" / f"{ARM}.json").read_text())
    embedded = {k: root[k] for k in ("format", "description", "root_joint", "gravity")}
    spec = {"source": "upload", "id": ARM, "record": {**embedded, "name": "arm", "warnings": []}}
    payload = {**tip_payload("link2", mass)[0], "inertia": [[0.0] * 3] * 3}
    placed = [PlacedPayload.from_dict(payload)]
    record: dict = {}
    for level in range(1, levels + 1):
        model_id = variant_id(spec["id"], placed, {})
        record = {"format": "variant", "base": spec, "locked_joints": {}, "payloads": [payload]}
        record.update(name=f"level {level}", warnings=[])
        spec = {"source": "upload", "id": model_id, "record": record}
    summary = {"id": spec["id"], "name": f"level {levels}", "source": "upload", "nq": 2, "nv": 2}
    top = {**record, "id": spec["id"], "summary": {**summary, "root_joint": "fixed"}}
    (data / "models").mkdir(parents=True, exist_ok=True)
    (data / "models" / f"{spec['id']}.json").write_text(json.dumps(top))
    return str(spec["id"])


def test_a_deep_nested_record_loads_and_is_over_the_cap(tmp_path) -> None:
    """40 levels in the nested form (checking it level by level doubled the work per level):
    it loads, rebuilds with every payload, and a variant of it is refused (422)."""
    levels = MAX_VARIANT_DEPTH + 8
    data = tmp_path / "data"
    deepest = _nested_chain(data, levels, 0.05)
    record = ModelStore(data).read(deepest)
    assert record is not None and len(record["steps"]) == levels - 1
    reg = registry(data)
    robot = reg.get(deepest)
    q = np.array([0.7, 0.5])
    want = arm_mass_matrix(M1, M2 + levels * 0.05, q)
    np.testing.assert_allclose(mass_matrix(robot, q), want, rtol=1e-12)
    with pytest.raises(InvalidInput, match=f"{levels} levels deep.*at most {MAX_VARIANT_DEPTH}"):
        reg.variant(deepest, payloads=check_payloads(robot, tip_payload("link1", 1.0)))


def test_a_nested_record_with_a_broken_level_is_refused_naming_it() -> None:
    """(`ModelStore.read` skips such a record with one log line: test_store_schema.py.)"""
    record = json.loads((NESTED / "models" / f"{ARM_CHAIN[-1]}.json").read_text())
    broken = json.loads(json.dumps(record))
    broken["base"]["record"]["payloads"][0]["mass"] = "heavy"  # its parent's payload
    with pytest.raises(ValueError, match=r"steps\.2\.payloads\.0\.mass"):
        check_record(broken, ARM_CHAIN[-1])
    cut = json.loads(json.dumps(record))
    cut["base"]["record"]["base"]["record"]["base"] = "u-gone"
    with pytest.raises(ValueError, match="incomplete record: base"):
        check_record(cut, ARM_CHAIN[-1])


def test_variants_deeper_than_the_cap_are_a_422_naming_it(small_app_factory) -> None:
    api = small_app_factory(catalog="planar_arm")
    body = {"payloads": [{"frame": "link2", "mass": 0.1}]}
    parent = "planar_arm"
    for level in range(1, MAX_VARIANT_DEPTH + 1):
        r = api.post(f"/v1/robots/{parent}/variants", json=body)
        assert r.status_code == 201, (level, r.text)
        parent = r.json()["id"]
    deepest = api.get(f"/v1/robots/{parent}").json()
    closest = api.get("/v1/robots/planar_arm").json()
    assert deepest["total_mass"] == pytest.approx(closest["total_mass"] + 0.1 * MAX_VARIANT_DEPTH)
    for route, extra in (("variants", body), ("reduce", {"locked_joints": {"elbow": 0.2}})):
        r = api.post(f"/v1/robots/{parent}/{route}", json=extra)
        assert r.status_code == 422, r.text
        problem = r.json()
        assert r.headers["content-type"].startswith("application/problem+json")
        assert problem["code"] == "validation_error"
        assert f"at most {MAX_VARIANT_DEPTH} levels deep" in problem["detail"]
        assert (
            parent in problem["detail"] and f"{MAX_VARIANT_DEPTH} levels deep" in problem["detail"]
        )


def test_start_up_reads_no_record_and_builds_on_first_use(tmp_path, monkeypatch) -> None:
    data = nested_store(tmp_path)
    reads: list[str] = []
    real_read = ModelStore.read

    def counted(store: ModelStore, model_id: str):
        reads.append(model_id)
        return real_read(store, model_id)

    monkeypatch.setattr(ModelStore, "read", counted)
    reg = registry(data)
    assert reads == [] and reg.uploads == {}
    reg.get(ARM_CHAIN[1])
    assert reads == [ARM_CHAIN[1]] and set(reg.uploads) == {ARM_CHAIN[1]}
    # a page of the list reads the records it lists, and no other
    first = min([ARM, *ARM_CHAIN, *UR5_CHAIN])  # stored models are listed by id
    page = reg.robot_page(2)
    assert [r["id"] for r in page.robots] == ["ur5", first] and reads[1:] == [first]


def test_fitted_steps_keep_their_values_in_a_new_lineage(tmp_path) -> None:
    """A variant made from an identified one (friction only) rebuilt from its flat record
    after its parent is deleted keeps the friction."""
    reg = registry(tmp_path, ["planar_arm"])
    fitted, _ = reg.variant("planar_arm", fitted=Fitted(friction=FRICTION))
    child, _ = reg.reduce(fitted.id, {"shoulder": 0.1})
    reg.delete(fitted.id)
    rebuilt = registry(tmp_path, ["planar_arm"]).get(child.id)
    assert rebuilt.info()["friction"] == [dict(zip(FRICTION_KEYS, FRICTION[1], strict=True))]


def test_a_first_use_builds_off_the_event_loop(tmp_path, monkeypatch) -> None:
    """Over HTTP, the first request for a stored model not built yet builds it in a worker
    thread (`served_robot`); the next requests find it built and answer on the event loop."""
    from service.api import deps
    from tests.helpers import registry_client

    reg = registry(nested_store(tmp_path))
    threaded: list[str] = []
    real = deps.run_in_threadpool

    async def recording(fn, *args):
        threaded.append(args[0])
        return await real(fn, *args)

    monkeypatch.setattr(deps, "run_in_threadpool", recording)
    robot_id = ARM_CHAIN[1]
    assert not reg.built(robot_id) and reg.built("ur5")
    with registry_client(reg) as client:
        first = client.post(f"/v1/robots/{robot_id}/gravity", json={"q": [0.3, -0.2]})
        again = client.post(f"/v1/robots/{robot_id}/gravity", json={"q": [0.3, -0.2]})
        info = client.get(f"/v1/robots/{robot_id}")
    assert first.status_code == again.status_code == info.status_code == 200, first.text
    assert first.json() == again.json()
    assert threaded == [robot_id] and reg.built(robot_id)
