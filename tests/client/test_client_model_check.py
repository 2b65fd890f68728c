"""`model_check` and `variant(..., inertias=...)`, sync and async, against the real app: the
answer is the route's, typed; a repaired variant and an upload with `inertia_check="repair"`
have no error left; a malformed `inertias` is refused before anything is sent."""

from __future__ import annotations

import numpy as np
import pytest
from robodyn import InputError, LinkCheck, ModelCheck

from tests.client.helpers import two_link_urdf

# the forearm's izz a hundred times too large: λ₁ + λ₂ < λ₃
BROKEN = two_link_urdf(name="broken_arm").replace(
    'iyz="0" izz="0.020000000000000004"', 'iyz="0" izz="2.0"'
)


def test_the_model_check_is_the_routes_answer_typed(client):
    check = client.model_check("ur5")
    assert isinstance(check, ModelCheck) and not check.errors
    raw = client._http.get("/v1/robots/ur5/model-check").json()
    assert [f.code for f in check.findings] == [f["code"] for f in raw["findings"]]
    arm = check.links_by_name["upper_arm_link"]
    assert isinstance(arm, LinkCheck) and arm.geometry is not None
    expected = next(link for link in raw["links"] if link["name"] == "upper_arm_link")
    np.testing.assert_array_equal(arm.geometry.inertia, expected["geometry"]["inertia"])
    np.testing.assert_array_equal(arm.principal_moments, expected["principal_moments"])
    assert arm.geometry.density == expected["geometry"]["density"]


def test_a_variant_repairs_the_errors_the_check_finds(client):
    assert 'izz="2.0"' in BROKEN
    robot = client.upload(BROKEN, inertia_check="warn")
    errors = client.model_check(robot.id).errors
    assert [(e.link, e.code) for e in errors] == [("fore", "triangle_inequality")]
    fixed = client.variant(robot.id, inertias={"links": "errors", "from": "nearest_valid"})
    assert fixed.parent == robot.id and "inertias" in fixed.modifications
    assert not client.model_check(fixed.id).errors
    repaired = client.upload(BROKEN, inertia_check="repair")
    assert [w.code for w in repaired.warnings] == ["inertia_repaired"]
    assert not client.model_check(repaired.id).errors


@pytest.mark.anyio
async def test_the_async_client_checks_and_repairs_alike(aclient):
    robot = await aclient.upload(BROKEN, inertia_check="warn")
    assert [e.link for e in (await aclient.model_check(robot.id)).errors] == ["fore"]
    fixed = await aclient.variant(robot.id, inertias={"links": ["fore"], "from": "nearest_valid"})
    assert not (await aclient.model_check(fixed.id)).errors


@pytest.mark.parametrize(
    "inertias",
    [{"links": "errors"}, {"from": "geometry"}, ["fore"], {"links": 1, "from": 2, "x": 3}],
)
def test_a_malformed_repair_is_refused_before_sending(client, inertias):
    with pytest.raises(InputError, match="inertias must be"):
        client.variant("ur5", inertias=inertias)
