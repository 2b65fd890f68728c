"""`reduce(...)` and `upload(mjcf=..., locked_joints=...)`, sync against a real server (including
a restart) and async against the app in process, plus the local argument checks."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
import robodyn
from robodyn import AsyncClient, Client

from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.client.helpers import API_KEY, running_server
from tests.service.registry.mjcf_models import PLANAR_ARM_MJCF

LOCK = {"wrist_1_joint": 0.3, "elbow_joint": -1.0}
UR5_FREE_V = [0, 1, 4, 5]  # velocity entries of ur5 left free by LOCK


def _block_of_full(client: Any, q_reduced: np.ndarray) -> np.ndarray:
    q = np.insert(q_reduced, [2, 2], [-1.0, 0.3])  # elbow (index 2), wrist_1 (index 3)
    return client.mass_matrix("ur5", q)[np.ix_(UR5_FREE_V, UR5_FREE_V)]


def test_sync_client_against_a_real_server_and_its_restart(tmp_path: Path) -> None:
    q = np.array([0.1, -0.4, 0.7, 1.2])
    with (
        running_server(tmp_path, catalog="ur5,planar_arm", api_keys=API_KEY) as url,
        Client(url, api_key=API_KEY) as client,
    ):
        info = client.reduce("ur5", LOCK, name="ur5 without elbow and wrist 1")
        assert info.created is True and info.id.startswith("r-") and (info.nq, info.nv) == (4, 4)
        assert info.raw["reduced_from"] == {
            "robot": "ur5",
            "locked_joints": {"elbow_joint": [-1.0], "wrist_1_joint": [0.3]},
        }
        assert client.reduce("ur5", {"elbow_joint": [-1.0], "wrist_1_joint": 0.3}).created is False
        M = client.mass_matrix(info.id, q)
        np.testing.assert_allclose(M, _block_of_full(client, q), rtol=1e-12, atol=1e-12)

        arm = client.upload(mjcf=PLANAR_ARM_MJCF)
        q_arm = np.array([[0.3, -0.5], [1.0, 0.2]])
        np.testing.assert_allclose(
            client.mass_matrix(arm.id, q_arm), client.mass_matrix("planar_arm", q_arm), rtol=1e-12
        )
        locked = client.upload(mjcf=PLANAR_ARM_MJCF, locked_joints={"elbow": 0.5})
        assert locked.created and locked.joint_names == ["shoulder"]
        with pytest.raises(robodyn.ValidationError, match="'knee'"):
            client.reduce("ur5", {"knee": 1.0})
        with pytest.raises(robodyn.InvalidConfigurationError, match="outside its position"):
            client.reduce("ur5", {"elbow_joint": 4.0})
        with pytest.raises(robodyn.InvalidModelError, match=r"a\.xml"):  # not among the assets
            client.upload(mjcf="<mujoco model='x'><include file='a.xml'/></mujoco>")
        with Client(url) as anonymous, pytest.raises(robodyn.UnauthorizedError):
            anonymous.reduce("ur5", LOCK)
    # a new server process on the same data directory serves the same models
    with running_server(tmp_path, catalog="planar_arm") as url, Client(url) as client:
        again = client.robot(info.id)
        assert again.raw == info.raw and client.robot(arm.id).raw == arm.raw
        np.testing.assert_array_equal(client.mass_matrix(info.id, q), M)


@pytest.mark.anyio
async def test_async_client_in_process(tmp_path: Path) -> None:
    registry = Registry(tmp_path, ["ur5", "planar_arm"])
    registry.load()
    transport = httpx.ASGITransport(app=create_app(Settings(data_dir=tmp_path), registry=registry))
    async with (
        httpx.AsyncClient(transport=transport, base_url="http://robodyn.test") as http,
        AsyncClient(http_client=http) as client,
    ):
        info = await client.reduce("ur5", LOCK)
        assert info.created is True and info.nv == 4
        q = np.array([[0.1, -0.4, 0.7, 1.2], [0.0, 0.5, -0.5, 2.0]])
        M = await client.mass_matrix(info.id, q)
        for row, Mi in zip(q, M, strict=True):
            q_full = np.insert(row, [2, 2], [-1.0, 0.3])
            full = await client.mass_matrix("ur5", q_full)
            np.testing.assert_allclose(Mi, full[np.ix_(UR5_FREE_V, UR5_FREE_V)], rtol=1e-12)
        arm = await client.upload(mjcf=PLANAR_ARM_MJCF.encode(), locked_joints={"shoulder": 0})
        assert arm.joint_names == ["elbow"] and arm.raw["reduced_from"]["locked_joints"] == {
            "shoulder": [0.0]
        }
        full = await client.upload(mjcf=PLANAR_ARM_MJCF)
        elbow_locked = await client.reduce(full.id, {"elbow": 0.1}, name="x")
        assert elbow_locked.joint_names == ["shoulder"] and elbow_locked.name == "x"
        with pytest.raises(robodyn.InvalidModelError, match="nothing to move"):
            await client.reduce(arm.id, {"elbow": 0.1})


class Recorder:
    def __init__(self) -> None:
        self.bodies: list[Any] = []

    def __call__(self, request: httpx.Request) -> httpx.Response:
        self.bodies.append(json.loads(request.content))
        info = {
            "id": "r-1",
            "name": "r",
            "source": "upload",
            "nq": 1,
            "nv": 1,
            "root_joint": "fixed",
            "gravity": [0, 0, -9.81],
            "total_mass": 1.0,
            "neutral_configuration": [0.0],
            "reference_configurations": {},
            "warnings": [],
            "joints": [],
            "frames": [],
        }
        return httpx.Response(201, json=info)


def test_request_bodies_and_local_checks(tmp_path: Path) -> None:
    recorder = Recorder()
    http = httpx.Client(transport=httpx.MockTransport(recorder), base_url="http://mock")
    path = tmp_path / "arm.xml"
    path.write_text(PLANAR_ARM_MJCF)
    with Client(http_client=http) as client:
        client.reduce("ur5", {"a": np.float32(0.5), "b": np.array([1, 2]), "c": [0.25]}, name="n")
        client.upload(mjcf=path, locked_joints={"elbow": 0.5}, gravity=[0, 0, -1])
        for bad, match in (
            ({"a": float("nan")}, "finite"),
            ({}, "non-empty"),
            ({"a": [[1.0]]}, "1-D"),
            ({"a": "x"}, "number"),
            ({1: 0.0}, "joint names"),
        ):
            with pytest.raises(robodyn.InputError, match=match):
                client.reduce("ur5", bad)  # type: ignore[arg-type]
        with pytest.raises(robodyn.InputError, match="exactly one"):
            client.upload()
        with pytest.raises(robodyn.InputError, match="exactly one"):
            client.upload("<robot/>", mjcf="<mujoco/>")
    assert recorder.bodies == [
        {"locked_joints": {"a": 0.5, "b": [1.0, 2.0], "c": [0.25]}, "name": "n"},
        {
            "mjcf": PLANAR_ARM_MJCF,
            "root_joint": "fixed",
            "gravity": [0.0, 0.0, -1.0],
            "locked_joints": {"elbow": 0.5},
        },
    ]
