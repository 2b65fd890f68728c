"""The hostile corpus against the app in-process (wired as in production): every case gets its
expected answer, no answer leaks a path or echoes the input, and the service keeps serving an
earlier upload and its health endpoint afterwards."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from tests.hardening.conftest import LEAK
from tests.hardening.corpus import CASES, Case
from tests.helpers import planar_arm_closed_form, planar_arm_urdf

SENTINEL = planar_arm_urdf(0.7, 0.5, 1.5, 0.5)
CATEGORIES = (
    "malformed",
    "wrong-root",
    "structure",
    "numbers",
    "physics",
    "entities",
    "meshes",
    "assets",
    "huge",
    "unicode",
    "request",
)


def test_the_corpus_is_large_and_covers_every_category():
    counts = Counter(c.category for c in CASES)
    assert len(CASES) >= 40
    assert set(counts) == set(CATEGORIES), counts
    assert all(counts[c] >= 2 for c in CATEGORIES), counts


def check_answer(case: Case, r) -> None:
    assert r.status_code == case.status, (case.id, r.text[:500])
    if case.status == 201:
        info = r.json()
        assert case.accepted is not None and case.accepted(info), (case.id, info)
        return
    assert r.headers["content-type"].startswith("application/problem+json"), case.id
    body = r.json()
    assert body["code"] == case.code and body["status"] == case.status, (case.id, body)
    if case.fragment is not None:
        assert case.fragment in body["detail"], (case.id, body["detail"])
    assert not LEAK.search(r.text), (case.id, r.text)
    assert len(r.text) < 4000, (case.id, "the answer echoes the input")


@pytest.fixture(scope="module")
def corpus_client(tmp_path_factory):
    from fastapi.testclient import TestClient

    from service.main import create_app
    from service.settings import Settings
    from tests.hardening.conftest import wait_ready

    settings = Settings(data_dir=tmp_path_factory.mktemp("corpus"), catalog="ur5")
    with TestClient(create_app(settings), raise_server_exceptions=False) as client:
        wait_ready(client.get)
        first = client.post("/v1/robots", json={"urdf": SENTINEL})
        assert first.status_code == 201, first.text
        client.sentinel = first.json()["id"]  # type: ignore[attr-defined]
        yield client


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_hostile_upload(corpus_client, case):
    r = corpus_client.post(
        "/v1/robots", content=case.content(), headers={"content-type": "application/json"}
    )
    check_answer(case, r)
    if case.status == 201:  # an accepted model computes
        info = r.json()
        g = corpus_client.post(
            f"/v1/robots/{info['id']}/gravity", json={"q": info["neutral_configuration"]}
        )
        assert g.status_code == 200, g.text
    # the service is alive and still serves the earlier upload, correctly
    assert corpus_client.get("/health/live").json() == {"status": "ok"}
    q = [0.3, -0.2]
    M = corpus_client.post(f"/v1/robots/{corpus_client.sentinel}/mass-matrix", json={"q": q})
    expected, _, _ = planar_arm_closed_form(0.7, 0.5, 1.5, 0.5, np.array(q), np.zeros(2))
    np.testing.assert_allclose(M.json()["mass_matrix"], expected, rtol=1e-10)
