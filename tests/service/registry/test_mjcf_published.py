"""Unmodified MJCF models shipped in PyPI packages, uploaded with their assets: dm_control's
control suite (`dm_control/suite/*.xml` with `common/` and the dog's meshes), Gymnasium's MuJoCo
environments (`gymnasium/envs/mujoco/assets/*.xml`) and MuJoCo's own test model
(`mujoco/testdata/model.xml`: free, ball, slide and hinge joints, equality constraints,
tendons). Over HTTP, robodyn's M(q) equals MuJoCo's `mj_fullM` and its nonlinear effects equal
`qfrc_bias`, relative 1e-10, at random states."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.service.registry.mjcf_reference import (
    DM_SUITE,
    MUJOCO_TESTDATA,
    directory_assets,
    encoded,
)
from tests.service.registry.test_mjcf import assert_as_mujoco

SUITE = sorted(p.name for p in DM_SUITE.glob("*.xml") if p.name != "lqr.xml")
GYMNASIUM = (
    Path(importlib.util.find_spec("gymnasium").submodule_search_locations[0])
    / "envs"
    / "mujoco"
    / "assets"
)
GYM_MODELS = sorted(p.name for p in GYMNASIUM.glob("*.xml"))


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> TestClient:
    registry = Registry(tmp_path_factory.mktemp("published"), ["ur5"])
    registry.load()
    app = create_app(Settings(data_dir=registry.store.dir.parent), registry=registry)
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c


def test_the_suite_is_there() -> None:
    assert len(SUITE) >= 17 and "humanoid_CMU.xml" in SUITE and "dog.xml" in SUITE


@pytest.mark.parametrize("name", SUITE)
def test_dm_control_suite_model_as_mujoco(client: TestClient, name: str) -> None:
    folders = ("common", "dog_assets") if name == "dog.xml" else ("common",)
    files = directory_assets(DM_SUITE, *folders)
    info = assert_as_mujoco(client, (DM_SUITE / name).read_text(), files, states=3)
    if name == "dog.xml":
        assert info["nv"] > 80 and any(w["code"] == "ignored_tendon" for w in info["warnings"])


def test_gymnasium_models_are_there() -> None:
    assert len(GYM_MODELS) >= 10 and "ant.xml" in GYM_MODELS


@pytest.mark.parametrize("name", GYM_MODELS)
def test_gymnasium_model_as_mujoco(client: TestClient, name: str) -> None:
    assert_as_mujoco(client, (GYMNASIUM / name).read_text(), states=3)


def test_mujoco_test_model_as_mujoco(client: TestClient) -> None:
    info = assert_as_mujoco(client, (MUJOCO_TESTDATA / "model.xml").read_text(), states=4)
    codes = {w["code"] for w in info["warnings"]}
    assert {"ignored_equality", "ignored_tendon"} <= codes


def test_a_model_without_joints_is_refused(client: TestClient) -> None:
    r = client.post(
        "/v1/robots",
        json={
            "mjcf": (DM_SUITE / "lqr.xml").read_text(),
            "assets": encoded(directory_assets(DM_SUITE, "common")),
        },
    )
    assert r.status_code == 422 and "nothing can move" in r.json()["detail"]
