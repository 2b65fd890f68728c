"""Property tests (hypothesis) of the validators: no input makes them fail other than with
InvalidModel; descriptions of real rigid bodies never produce inertia findings and agree with
Pinocchio; implausible tensors are found whatever their orientation; numbers are read strictly;
the XML caps hold exactly."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from service.errors import InvalidModel
from service.registry.safe_xml import parse_bounded, read_numbers
from service.registry.urdf_check import Limits, _inertia_findings, check_urdf
from tests.hardening.corpus import CASES, LIMIT

FAST = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def rotation(angles: tuple[float, float, float]) -> np.ndarray:
    return pin.rpy.rpyToMatrix(*angles)


def body_inertia(masses: list[float], points: list[tuple[float, float, float]]) -> np.ndarray:
    """Inertia about the centre of mass of point masses: a real rigid body."""
    m = np.asarray(masses)
    p = np.asarray(points, dtype=float)
    c = (m[:, None] * p).sum(0) / m.sum()
    r = p - c
    return sum(mi * (ri @ ri * np.eye(3) - np.outer(ri, ri)) for mi, ri in zip(m, r, strict=True))


coords = st.floats(-1, 1, allow_nan=False)
point_sets = st.integers(2, 6).flatmap(
    lambda n: st.tuples(
        st.lists(st.floats(0.01, 10), min_size=n, max_size=n),
        st.lists(st.tuples(coords, coords, coords), min_size=n, max_size=n),
    )
)
angles = st.tuples(*[st.floats(-np.pi, np.pi)] * 3)


@FAST
@given(point_sets, angles)
def test_real_bodies_have_no_findings_in_any_orientation(bodies, rpy):
    tensor = body_inertia(*bodies)
    R = rotation(rpy)
    assert _inertia_findings("b", tensor) == []
    assert _inertia_findings("b", R @ tensor @ R.T) == []


@FAST
@given(st.floats(0.01, 1), st.floats(0.01, 1), st.floats(0.05, 1), angles)
def test_negative_moments_are_found_in_any_orientation(a, b, neg, rpy):
    R = rotation(rpy)
    tensor = R @ np.diag([a, b, -neg * max(a, b)]) @ R.T
    found = _inertia_findings("b", tensor)
    assert [f.code for f in found] == ["negative_principal_moment"]
    assert "link 'b'" in found[0].message


@FAST
@given(st.floats(0.01, 1), st.floats(0.01, 1), st.floats(0.01, 1), angles)
def test_triangle_violations_are_found_in_any_orientation(a, b, excess, rpy):
    R = rotation(rpy)
    tensor = R @ np.diag([a, b, (a + b) * (1 + excess)]) @ R.T
    assert [f.code for f in _inertia_findings("b", tensor)] == ["triangle_inequality"]


@FAST
@given(st.floats(1e-6, 10), st.floats(0, 1e-7), angles)
def test_rounding_level_negatives_are_not_findings(scale, eps, rpy):
    R = rotation(rpy)  # a thin rod along one axis, with a rounding-level negative moment
    tensor = R @ np.diag([scale, scale, -eps * scale]) @ R.T
    assert _inertia_findings("b", tensor) == []


def tree_urdf(parents: list[int], bodies: list[tuple[list[float], list]], axes: list[int]) -> str:
    links = ["<link name='l0'/>"]
    joints = []
    for i, (parent, body, axis) in enumerate(zip(parents, bodies, axes, strict=True), start=1):
        I = body_inertia(*body).tolist()  # noqa: E741
        m = float(sum(body[0]))
        links.append(
            f"<link name='l{i}'><inertial><origin xyz='0.1 0 0'/><mass value='{m!r}'/>"
            f"<inertia ixx='{I[0][0]!r}' ixy='{I[0][1]!r}' ixz='{I[0][2]!r}' "
            f"iyy='{I[1][1]!r}' iyz='{I[1][2]!r}' izz='{I[2][2]!r}'/></inertial></link>"
        )
        xyz = " ".join("1" if k == axis else "0" for k in range(3))
        joints.append(
            f"<joint name='j{i}' type='revolute'><parent link='l{parent}'/>"
            f"<child link='l{i}'/><origin xyz='0 0 0.2'/><axis xyz='{xyz}'/>"
            f"{LIMIT}</joint>"
        )
    return f"<robot name='tree'>{''.join(links + joints)}</robot>"


trees = st.integers(1, 8).flatmap(
    lambda n: st.tuples(
        st.tuples(*[st.integers(0, i) for i in range(n)]),
        st.lists(point_sets, min_size=n, max_size=n),
        st.lists(st.integers(0, 2), min_size=n, max_size=n),
    )
)


@settings(max_examples=60, deadline=None)
@given(trees)
def test_valid_trees_pass_and_agree_with_pinocchio(tree):
    parents, bodies, axes = tree
    text = tree_urdf(list(parents), bodies, axes)
    summary = check_urdf(text)
    model = pin.buildModelFromXML(text)
    assert summary.findings == []
    assert summary.nv == model.nv == len(parents)
    assert summary.links == len(parents) + 1
    depth = {0: 0}
    for i, p in enumerate(parents, start=1):
        depth[i] = depth[p] + 1
    assert summary.depth == max(depth.values())
    masses = [sum(b[0]) for b in bodies]
    assert np.isclose(pin.computeTotalMass(model), sum(masses), rtol=1e-12)
    limits = Limits(max_nv=len(parents) - 1, max_depth=summary.depth)
    if len(parents) > 1:
        with pytest.raises(InvalidModel, match="ROBODYN_MAX_NV"):
            check_urdf(text, limits)


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=300))
def test_arbitrary_text_is_rejected_cleanly_or_accepted(text):
    try:
        check_urdf(text)
    except InvalidModel as exc:
        assert exc.detail and len(exc.detail) < 1000


valid_texts = [c.body["urdf"] for c in CASES if c.status == 201 and isinstance(c.body, dict)]


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(valid_texts), st.data())
def test_mutated_descriptions_are_rejected_cleanly_or_accepted(text, data):
    start = data.draw(st.integers(0, len(text)))
    end = data.draw(st.integers(start, min(len(text), start + 20)))
    junk = data.draw(st.text(max_size=10))
    mutated = text[:start] + junk + text[end:]
    try:
        check_urdf(mutated)
    except InvalidModel as exc:
        assert exc.detail and len(exc.detail) < 1000


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_plain_decimals_read_exactly(x):
    assert read_numbers(repr(x), 1, "x") == [x]
    assert read_numbers(f"{x:.6e}", 1, "x") == [float(f"{x:.6e}")]


@given(
    st.sampled_from(
        [
            "nan",
            "NaN",
            "-inf",
            "Infinity",
            "1_0",
            "0x1",
            "\u0661",
            "1e",
            "--1",
            "1.2.3",
            "",
            "١٢",
            "1e99999",
        ]
    )
)
def test_odd_numbers_are_refused(raw):
    with pytest.raises(InvalidModel):
        read_numbers(raw, 1, "x")


@given(st.integers(1, 60), st.integers(1, 60))
def test_xml_depth_cap_is_exact(depth, cap):
    text = "<a>" * depth + "</a>" * depth
    if depth <= cap:
        assert parse_bounded(text, 10_000, cap).tag == "a"
    else:
        with pytest.raises(InvalidModel, match="nested deeper"):
            parse_bounded(text, 10_000, cap)


@given(st.integers(1, 300), st.integers(1, 300))
def test_xml_element_cap_is_exact(count, cap):
    text = "<a>" + "<b/>" * (count - 1) + "</a>"
    if count <= cap:
        assert len(parse_bounded(text, cap, 8)) == count - 1
    else:
        with pytest.raises(InvalidModel, match="XML elements"):
            parse_bounded(text, cap, 8)
