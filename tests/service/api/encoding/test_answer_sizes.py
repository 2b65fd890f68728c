"""The size of an answer is known before computing it, as an upper bound of what is really
sent (`service.api.encoding.budget.answer_bytes`): never under, and within a few percent in
the binary form (the numbers are float64, exactly 8 bytes). Binary answers with
`"joint_names": true` keep their arrays and name the joints once, so any safetensors reader
opens them, however long the trajectory."""

from __future__ import annotations

import numpy as np
import pytest
import safetensors.numpy
from robodyn.binary import decode as client_decode

from service.api.encoding.binary import BINARY_MEDIA_TYPE
from service.api.encoding.budget import answer_bytes
from service.dynamics import QUANTITIES
from tests.service.dynamics.contacts.test_quantities import contacts_of

UR5_Q = [0.1, -1.0, 1.2, 0.3, 0.5, -0.2]
N = 2_000
CASES = {  # quantity: (robot, body) — answers of about 0.3 to 3 MB in the binary form
    "mass-matrix": ("ur5", {"q": [UR5_Q] * N}),
    "gravity": ("talos", None),
    "jacobian": ("ur5", {"q": [UR5_Q] * N, "frame": "tool0"}),
    "inverse-dynamics": (
        "ur5",
        {"q": [UR5_Q] * 10 * N, "v": [[0.3] * 6] * 10 * N, "a": [[-0.2] * 6] * 10 * N},
    ),
    "simulate": ("ur5", {"q": UR5_Q, "v": [0.0] * 6, "dt": 1e-3, "steps": 5_000}),
    "frame-placements": ("ur5", {"q": [UR5_Q] * N}),
    "contact-dynamics": ("solo12", None),
}


def _body(catalog_registry, quantity: str) -> tuple[str, dict]:
    robot, body = CASES[quantity]
    if body is None:
        r = catalog_registry.catalog[robot]
        rng = np.random.default_rng(1)
        q = np.repeat(r.default_configuration[None], 4_000, 0)
        q[:, 7:] += rng.normal(0, 0.2, (4_000, r.nq - 7))
        body = {"q": q.tolist()}
        if quantity == "contact-dynamics":
            body.update(
                v=rng.normal(0, 0.1, (4_000, r.nv)).tolist(),
                tau=rng.normal(0, 1, (4_000, r.nv)).tolist(),
                contacts=contacts_of(robot),
            )
    return robot, body


@pytest.mark.parametrize("named", [False, True])
@pytest.mark.parametrize("binary", [False, True])
@pytest.mark.parametrize("quantity", list(CASES))
def test_the_size_estimate_bounds_the_answer_closely(
    api, catalog_registry, quantity, binary, named
):
    robot_id, body = _body(catalog_registry, quantity)
    robot = catalog_registry.catalog[robot_id]
    headers = {"accept": BINARY_MEDIA_TYPE} if binary else {}
    r = api.post(
        f"/v1/robots/{robot_id}/{quantity}", json={**body, "joint_names": named}, headers=headers
    )
    assert r.status_code == 200, r.text[:300]
    options = {k: v for k, v in body.items() if k not in ("q", "v", "a", "tau")}
    states = len(body["q"]) if isinstance(body["q"][0], list) else 1
    estimate = answer_bytes(
        QUANTITIES[quantity], robot, options, "v" in body, states, binary, named
    )
    actual = len(r.content)
    assert estimate >= actual
    if binary:  # float64: 8 bytes a number, whatever the names
        assert estimate <= 1.03 * actual, (estimate, actual)
    else:  # the longest text of a number (24 characters) is counted for each, and of a
        # joint name for each keyed number: real ones are shorter (0.0, 1.0 in placements)
        assert estimate <= (2.0 if named else 1.8) * actual, (estimate, actual)


def test_a_long_trajectory_with_joint_names_is_a_safetensors_file(api, catalog_registry):
    """simulate with `"joint_names": true` in the binary form: q and v stay tensors (the
    40,000-step Talos answer was a 117 MB header no safetensors reader opens); the joint
    layout is given once in `__metadata__`; the Python client's reader reads it too."""
    talos = catalog_registry.catalog["talos"]
    steps = 4_000  # the header does not grow with the steps: see the slow twin below
    r = api.post(
        "/v1/robots/talos/simulate",
        headers={"accept": BINARY_MEDIA_TYPE},
        json={
            "q": talos.default_configuration.tolist(),
            "v": [0.0] * talos.nv,
            "dt": 1e-3,
            "steps": steps,
            "joint_names": True,
        },
    )
    assert r.status_code == 200, r.text[:300]
    _check_named_trajectory(r.content, talos, steps)


@pytest.mark.slow
def test_a_40000_step_trajectory_with_joint_names_is_a_safetensors_file(api, catalog_registry):
    talos = catalog_registry.catalog["talos"]
    r = api.post(
        "/v1/robots/talos/simulate",
        headers={"accept": BINARY_MEDIA_TYPE},
        json={
            "q": talos.default_configuration.tolist(),
            "v": [0.0] * talos.nv,
            "dt": 1e-4,
            "steps": 40_000,
            "joint_names": True,
        },
        timeout=300,
    )
    assert r.status_code == 200, r.text[:300]
    _check_named_trajectory(r.content, talos, 40_000)


def _check_named_trajectory(content: bytes, talos, steps: int) -> None:
    header_length = int.from_bytes(content[:8], "little")
    assert header_length < 16_384  # names once: a few kB whatever the steps
    tensors = safetensors.numpy.load(content)
    assert tensors["q"].shape == (steps + 1, talos.nq)
    assert tensors["v"].shape == (steps + 1, talos.nv)
    answer = client_decode(content)
    np.testing.assert_array_equal(answer["q"], tensors["q"])
    layout = answer["joint_names"]
    assert set(layout) == {"q", "v"}
    joints = {j["name"]: j for j in talos.info()["joints"]}
    for field, dim in (("q", "nq"), ("v", "nv")):
        covered = sorted((start, size) for _, start, size in layout[field])
        assert sum(size for _, size in covered) == getattr(talos, dim)
        for name, start, size in layout[field]:
            assert (start, size) == (
                joints[name]["idx_q" if dim == "nq" else "idx_v"],
                joints[name][dim],
            )
    root = next(start for name, start, _ in layout["q"] if name == "root_joint")
    np.testing.assert_array_equal(tensors["q"][0, root : root + 7], talos.default_configuration[:7])
