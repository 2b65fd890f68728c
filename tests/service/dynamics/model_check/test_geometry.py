"""Mass properties of link geometry: the primitives against the textbook's closed forms (the
uniform cube's I = m a²/6), a capsule against its parts composed by hand, meshes against two
independent implementations (coal, which reads the file with assimp and sums its own way, and
trimesh's `mass_properties`) on real collision meshes of example-robot-data, and elements placed
and added in a link frame against the parallel-axis theorem written out."""

from __future__ import annotations

import math
from pathlib import Path

import coal
import numpy as np
import pytest
import trimesh

from service.dynamics.model_check.geometry import (
    box,
    capsule,
    closed_mesh,
    convex_hull,
    cylinder,
    ellipsoid,
    sphere,
)
from service.dynamics.model_check.link_geometry import link_geometry
from service.registry.catalog import erd_robots_dir
from service.registry.link_descriptions import link_descriptions
from service.registry.meshes import read_mesh_file

TOL = 1e-9


def test_the_uniform_cube_has_m_a_squared_over_six_about_every_axis():
    a, m = 0.37, 2.5
    cube = box([a, a, a])
    assert cube.volume == pytest.approx(a**3, rel=TOL)
    np.testing.assert_allclose(cube.inertia * m / cube.volume, np.eye(3) * m * a * a / 6, rtol=TOL)
    np.testing.assert_array_equal(cube.center, np.zeros(3))


def test_box_cylinder_and_sphere_equal_their_closed_forms():
    a, b, c, m = 0.3, 0.5, 0.7, 4.0
    solid = box([a, b, c])
    assert solid.volume == pytest.approx(a * b * c, rel=TOL)
    expected = m / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    np.testing.assert_allclose(solid.inertia * m / solid.volume, expected, rtol=TOL, atol=0)

    r, h = 0.04, 0.3
    rod = cylinder(r, h)
    assert rod.volume == pytest.approx(math.pi * r * r * h, rel=TOL)
    side = m * (3 * r * r + h * h) / 12
    np.testing.assert_allclose(
        rod.inertia * m / rod.volume, np.diag([side, side, m * r * r / 2]), rtol=TOL
    )

    ball = sphere(r)
    assert ball.volume == pytest.approx(4 / 3 * math.pi * r**3, rel=TOL)
    np.testing.assert_allclose(
        ball.inertia * m / ball.volume, np.eye(3) * 0.4 * m * r * r, rtol=TOL
    )


def test_an_ellipsoid_equals_its_closed_form_and_a_sphere_when_round():
    a, b, c, m = 0.03, 0.05, 0.02, 1.5
    solid = ellipsoid([a, b, c])
    assert solid.volume == pytest.approx(4 / 3 * math.pi * a * b * c, rel=TOL)
    expected = m / 5 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    np.testing.assert_allclose(solid.inertia * m / solid.volume, expected, rtol=TOL, atol=0)
    round_one, ball = ellipsoid([a, a, a]), sphere(a)
    assert round_one.volume == pytest.approx(ball.volume, rel=TOL)
    np.testing.assert_allclose(round_one.inertia, ball.inertia, rtol=TOL)


def test_a_capsule_is_a_cylinder_and_two_hemispheres():
    r, h, rho = 0.05, 0.2, 1.0
    m_cyl, m_hemi = rho * math.pi * r * r * h, rho * 2 / 3 * math.pi * r**3
    # a hemisphere: centre 3r/8 from its flat face, 83/320 m r² across its axis about it
    offset = h / 2 + 3 * r / 8
    across = m_cyl * (3 * r * r + h * h) / 12 + 2 * (83 / 320 * m_hemi * r * r + m_hemi * offset**2)
    along = m_cyl * r * r / 2 + 2 * (0.4 * m_hemi * r * r)
    caps = capsule(r, h)
    assert caps.volume == pytest.approx(m_cyl + 2 * m_hemi, rel=TOL)
    np.testing.assert_allclose(caps.inertia, np.diag([across, across, along]), rtol=TOL)


def test_a_box_mesh_has_the_closed_form_of_its_box():
    extents = [0.2, 0.5, 0.9]
    mesh = trimesh.creation.box(extents=extents)
    shifted = np.asarray(mesh.vertices) + np.array([1.0, -2.0, 0.5])
    props = closed_mesh(shifted, np.asarray(mesh.faces))
    assert props is not None
    exact = box(extents)
    assert props.volume == pytest.approx(exact.volume, rel=TOL)
    np.testing.assert_allclose(props.center, [1.0, -2.0, 0.5], rtol=TOL)
    np.testing.assert_allclose(
        props.inertia, exact.inertia, rtol=TOL, atol=TOL * exact.inertia.max()
    )
    # wound inwards: the same solid
    inward = closed_mesh(shifted, np.asarray(mesh.faces)[:, ::-1])
    assert inward is not None and inward.volume == pytest.approx(exact.volume, rel=TOL)


def test_the_convex_hull_of_an_open_box_is_the_box():
    mesh = trimesh.creation.box(extents=[0.1, 0.2, 0.3])
    faces = np.asarray(mesh.faces)[2:]  # one side (two triangles) missing
    hull = convex_hull(np.asarray(mesh.vertices))
    assert hull is not None
    props = closed_mesh(*hull)
    assert props is not None
    assert props.volume == pytest.approx(0.1 * 0.2 * 0.3, rel=TOL)
    np.testing.assert_allclose(props.inertia, box([0.1, 0.2, 0.3]).inertia, rtol=TOL, atol=1e-15)
    assert len(faces) == 10


def _collision_meshes() -> list[Path]:
    root = erd_robots_dir()
    names = [
        *sorted((root / "ur_description/meshes/ur5/collision").glob("*.stl")),
        *sorted((root / "panda_description/meshes/collision").glob("*.stl"))[:3],
        root / "romeo_description/meshes/V1/collision/LWristYaw.dae",
    ]
    return [p for p in names if p.is_file()]


@pytest.mark.parametrize("path", _collision_meshes(), ids=lambda p: p.name)
def test_real_collision_meshes_equal_two_independent_libraries(path):
    triangles = read_mesh_file(path)
    assert triangles is not None
    if not triangles.closed:
        pytest.skip(f"{path.name} is not closed: its mass properties are its hull's")
    props = closed_mesh(triangles.vertices, triangles.faces)
    assert props is not None
    # coal: the file read by assimp, its own sums
    model = coal.MeshLoader().load(str(path))
    assert props.volume == pytest.approx(model.computeVolume(), rel=1e-6)
    scale = max(np.abs(props.bounds).max(), 1e-3)
    np.testing.assert_allclose(props.center, model.computeCOM(), rtol=0, atol=1e-6 * scale)
    reference = np.asarray(model.computeMomentofInertiaRelatedToCOM())
    np.testing.assert_allclose(
        props.inertia, reference, rtol=0, atol=1e-6 * np.abs(reference).max()
    )
    # trimesh's own mass properties at unit density
    mesh = trimesh.load(path, force="mesh")
    assert props.volume == pytest.approx(mesh.volume, rel=1e-6)
    np.testing.assert_allclose(
        props.inertia, mesh.moment_inertia, rtol=0, atol=1e-6 * np.abs(reference).max()
    )


def test_the_real_meshes_checked_include_closed_ones():
    closed = [p for p in _collision_meshes() if (t := read_mesh_file(p)) and t.closed]
    assert len(closed) >= 5


LINK = """<robot name="r"><link name="l">
  <collision><origin xyz="0.1 0.2 0.3" rpy="0.3 -0.4 1.1"/>
    <geometry><box size="0.2 0.1 0.4"/></geometry></collision>
  <collision><origin xyz="-0.2 0 0.05" rpy="0 1.5707963267948966 0"/>
    <geometry><cylinder radius="0.05" length="0.3"/></geometry></collision>
  <visual><geometry><sphere radius="9"/></geometry></visual>
</link></robot>"""


def _rotation(roll, pitch, yaw):
    cr, sr, cp, sp, cy, sy = (f(x) for x in (roll, pitch, yaw) for f in (math.cos, math.sin))
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def test_elements_are_placed_and_added_by_the_parallel_axis_theorem():
    link = link_descriptions(LINK)[0]
    shape = link_geometry(link, lambda key: None)
    assert shape is not None and shape.source == "collision"  # the visual sphere is not used
    v1, v2 = 0.2 * 0.1 * 0.4, math.pi * 0.05**2 * 0.3
    c1, c2 = np.array([0.1, 0.2, 0.3]), np.array([-0.2, 0.0, 0.05])
    j1 = v1 / 12 * np.diag([0.1**2 + 0.4**2, 0.2**2 + 0.4**2, 0.2**2 + 0.1**2])
    side = v2 * (3 * 0.05**2 + 0.3**2) / 12
    j2 = np.diag([side, side, v2 * 0.05**2 / 2])
    r1, r2 = _rotation(0.3, -0.4, 1.1), _rotation(0, math.pi / 2, 0)
    center = (v1 * c1 + v2 * c2) / (v1 + v2)
    expected = np.zeros((3, 3))
    for v, c, j, r in ((v1, c1, j1, r1), (v2, c2, j2, r2)):
        d = c - center
        expected += r @ j @ r.T + v * (d @ d * np.eye(3) - np.outer(d, d))
    props = shape.properties
    assert props.volume == pytest.approx(v1 + v2, rel=TOL)
    np.testing.assert_allclose(props.center, center, rtol=TOL)
    np.testing.assert_allclose(props.inertia, expected, rtol=TOL, atol=TOL * expected.max())


def test_a_mesh_is_scaled_before_it_is_placed(tmp_path):
    mesh = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    path = tmp_path / "unit.stl"
    mesh.export(path)
    urdf = """<robot name="r"><link name="l"><visual><origin xyz="0 0 1"/>
      <geometry><mesh filename="unit.stl" scale="0.1 0.2 0.3"/></geometry></visual>
      </link></robot>"""
    link = link_descriptions(urdf)[0]
    shape = link_geometry(link, lambda key: read_mesh_file(tmp_path / key))
    assert shape is not None and shape.source == "visual" and not shape.open_meshes
    exact = box([0.1, 0.2, 0.3])
    assert shape.properties.volume == pytest.approx(exact.volume, rel=TOL)
    np.testing.assert_allclose(shape.properties.center, [0, 0, 1], atol=TOL)
    np.testing.assert_allclose(shape.properties.inertia, exact.inertia, rtol=1e-7, atol=1e-12)
