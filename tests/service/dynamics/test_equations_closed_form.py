"""The derived equations of textbook arms equal their hand-derived closed forms, symbolically.

The expressions are read back from the answer's text (SymPy's `sympify`, decimals as exact
rationals) and compared with closed forms written with the same decimals: the difference,
rewritten in complex exponentials and expanded, must be exactly 0.
"""

from __future__ import annotations

import pinocchio as pin
import pytest
import sympy as sp

from service.dynamics.equations import derive_equations, equations_answer

R = sp.Rational
G0 = R("9.81")
q1, q2, q3, dq1, dq2, dq3 = sp.symbols("q1 q2 q3 dq1 dq2 dq3")
NAMES = {str(s): s for s in (q1, q2, q3, dq1, dq2, dq3)}
LIMIT = '<limit lower="-3.2" upper="3.2" effort="100" velocity="5"/>'


def _parse(value):
    if isinstance(value, str):
        return sp.sympify(value, locals=NAMES, rational=True)
    return [_parse(v) for v in value]


def _equal(a, b) -> bool:
    return sp.expand(sp.expand(a - b).rewrite(sp.exp)) == 0


def _assert_equal(derived, closed) -> None:
    if isinstance(closed, list):
        assert len(derived) == len(closed)
        for d, c in zip(derived, closed, strict=True):
            _assert_equal(d, c)
        return
    assert _equal(derived, closed), f"{derived} != {closed}"


def _answer(urdf: str) -> dict:
    return equations_answer(derive_equations(pin.buildModelFromXML(urdf)))


def _link(name: str, mass: str, xyz: str, iyy: str = "0", izz: str = "0", ixx: str = "0") -> str:
    return (
        f'<link name="{name}"><inertial><origin xyz="{xyz}"/><mass value="{mass}"/>'
        f'<inertia ixx="{ixx}" ixy="0" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/>'
        f"</inertial></link>"
    )


def _planar_2r(link1: str, link2: str, l1: str) -> str:
    """Two links in the x-z plane (gravity −z), both axes −y: angle 0 along +x, positive up."""
    return f"""<robot name="arm"><link name="base"/>{link1}{link2}
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="link1"/>
    <axis xyz="0 -1 0"/>{LIMIT}</joint>
  <joint name="elbow" type="revolute"><parent link="link1"/><child link="link2"/>
    <origin xyz="{l1} 0 0"/><axis xyz="0 -1 0"/>{LIMIT}</joint></robot>"""


def _coriolis_2r(h):
    """C of a 2R arm whose M12 = … + k cos q2 and M11 = … + 2 k cos q2 (h = −k sin q2)."""
    return [[h * dq2, h * (dq1 + dq2)], [-h * dq1, 0]]


def test_point_mass_2r_arm_textbook_form():
    l1, l2, m1, m2 = R("1.0"), R("0.7"), R("2.0"), R("1.5")
    urdf = _planar_2r(_link("link1", "2.0", "1.0 0 0"), _link("link2", "1.5", "0.7 0 0"), "1.0")
    ans = _answer(urdf)
    M = [
        [
            m1 * l1**2 + m2 * (l1**2 + l2**2 + 2 * l1 * l2 * sp.cos(q2)),
            m2 * (l2**2 + l1 * l2 * sp.cos(q2)),
        ],
        [m2 * (l2**2 + l1 * l2 * sp.cos(q2)), m2 * l2**2],
    ]
    g = [
        (m1 + m2) * G0 * l1 * sp.cos(q1) + m2 * G0 * l2 * sp.cos(q1 + q2),
        m2 * G0 * l2 * sp.cos(q1 + q2),
    ]
    C = _coriolis_2r(-m2 * l1 * l2 * sp.sin(q2))
    _assert_equal(_parse(ans["mass_matrix"]["expressions"]), M)
    _assert_equal(_parse(ans["gravity"]["expressions"]), g)
    _assert_equal(_parse(ans["coriolis_matrix"]["expressions"]), C)
    T = sp.Rational(1, 2) * (sp.Matrix([dq1, dq2]).T * sp.Matrix(M) * sp.Matrix([dq1, dq2]))[0]
    _assert_equal(_parse(ans["kinetic_energy"]["expressions"]), T)
    U = G0 * (m1 * l1 * sp.sin(q1) + m2 * (l1 * sp.sin(q1) + l2 * sp.sin(q1 + q2)))
    _assert_equal(_parse(ans["potential_energy"]["expressions"]), U)
    # sums of angles appear as such, and the constant entry is written as one number
    assert ans["mass_matrix"]["expressions"][0][0] == "4.235 + 2.1*cos(q2)"
    assert ans["mass_matrix"]["latex"][0][0] == r"4.235 + 2.1 \cos{\left(q_{2} \right)}"
    assert ans["gravity"]["expressions"][1] == "10.3005*cos(q1 + q2)"
    structure = ans["structure"]
    assert structure["mass_matrix"][0][0] == {
        "depends_on": ["q2"],
        "constant": False,
        "zero": False,
    }
    assert structure["mass_matrix"][1][1] == {"depends_on": [], "constant": True, "zero": False}
    assert structure["gravity"][0]["depends_on"] == ["q1", "q2"]
    assert ans["coordinates"] == ["q1", "q2"] and ans["velocities"] == ["dq1", "dq2"]
    assert ans["joints"] == ["shoulder", "elbow"]


@pytest.mark.parametrize("second", ["rod", "cube"])
def test_rod_and_cube_2r_arm(second):
    """Link 1 a uniform rod (I = m l²/12 about its centre); link 2 a rod, or a uniform cube of
    side a whose inertia about any axis through its centre is m a²/6."""
    l1, m1 = R("0.9"), R("1.2")
    i1 = m1 * l1**2 / 12  # 0.081
    link1 = _link("link1", "1.2", "0.45 0 0", iyy=str(float(i1)), izz=str(float(i1)))
    if second == "rod":
        m2, l2 = R("0.8"), R("0.6")
        d2, i2 = l2 / 2, m2 * l2**2 / 12  # 0.3, 0.024
        link2 = _link("link2", "0.8", "0.3 0 0", iyy=str(float(i2)), izz=str(float(i2)))
    else:
        m2, a, d2 = R("1.5"), R("0.2"), R("0.3")
        i2 = m2 * a**2 / 6  # 0.01
        link2 = _link(
            "link2", "1.5", "0.3 0 0", ixx=str(float(i2)), iyy=str(float(i2)), izz=str(float(i2))
        )
    ans = _answer(_planar_2r(link1, link2, "0.9"))
    d1 = l1 / 2
    M = [
        [
            i1 + m1 * d1**2 + i2 + m2 * (l1**2 + d2**2 + 2 * l1 * d2 * sp.cos(q2)),
            i2 + m2 * (d2**2 + l1 * d2 * sp.cos(q2)),
        ],
        [i2 + m2 * (d2**2 + l1 * d2 * sp.cos(q2)), i2 + m2 * d2**2],
    ]
    g = [
        G0 * ((m1 * d1 + m2 * l1) * sp.cos(q1) + m2 * d2 * sp.cos(q1 + q2)),
        G0 * m2 * d2 * sp.cos(q1 + q2),
    ]
    _assert_equal(_parse(ans["mass_matrix"]["expressions"]), M)
    _assert_equal(_parse(ans["gravity"]["expressions"]), g)
    _assert_equal(
        _parse(ans["coriolis_matrix"]["expressions"]), _coriolis_2r(-m2 * l1 * d2 * sp.sin(q2))
    )


def test_rp_arm_prismatic_coordinate_enters_polynomially():
    """A revolute joint (axis −y, angle from +x) carrying a slider along the link: m1 at l1 on
    the link, m2 on the slider at distance q2 from the axis."""
    l1, m1, m2 = R("0.5"), R("2.0"), R("1.5")
    urdf = f"""<robot name="rp"><link name="base"/>{_link("link1", "2.0", "0.5 0 0")}
      {_link("slider", "1.5", "0 0 0")}
      <joint name="turn" type="revolute"><parent link="base"/><child link="link1"/>
        <axis xyz="0 -1 0"/>{LIMIT}</joint>
      <joint name="slide" type="prismatic"><parent link="link1"/><child link="slider"/>
        <axis xyz="1 0 0"/>{LIMIT}</joint></robot>"""
    ans = _answer(urdf)
    M = [[m1 * l1**2 + m2 * q2**2, 0], [0, m2]]
    g = [G0 * (m1 * l1 + m2 * q2) * sp.cos(q1), G0 * m2 * sp.sin(q1)]
    C = [[m2 * q2 * dq2, m2 * q2 * dq1], [-m2 * q2 * dq1, 0]]
    christoffel = [[[0, m2 * q2], [m2 * q2, 0]], [[-m2 * q2, 0], [0, 0]]]
    _assert_equal(_parse(ans["mass_matrix"]["expressions"]), M)
    _assert_equal(_parse(ans["gravity"]["expressions"]), g)
    _assert_equal(_parse(ans["coriolis_matrix"]["expressions"]), C)
    _assert_equal(_parse(ans["christoffel"]["expressions"]), christoffel)
    assert ans["structure"]["mass_matrix"][0][1] == {
        "depends_on": [],
        "constant": True,
        "zero": True,
    }
    assert ans["structure"]["mass_matrix"][0][0]["depends_on"] == ["q2"]
    assert ans["mass_matrix"]["latex"][0][0] == r"0.5 + 1.5 q_{2}^{2}"


def test_spatial_3r_elbow_arm():
    """A vertical waist joint (z) with a body of inertia I1 about z, then shoulder and elbow
    about −y with point masses m2, m3 at the ends of links l2, l3 (d1 above the base)."""
    d1, l2, l3 = R("0.4"), R("0.6"), R("0.5")
    i1, m2, m3 = R("0.05"), R("3.0"), R("2.0")
    urdf = f"""<robot name="elbow"><link name="base"/>
      {_link("waist", "1.0", "0 0 0", ixx="0.05", iyy="0.05", izz="0.05")}
      {_link("upper", "3.0", "0.6 0 0")}{_link("fore", "2.0", "0.5 0 0")}
      <joint name="j1" type="revolute"><parent link="base"/><child link="waist"/>
        <axis xyz="0 0 1"/>{LIMIT}</joint>
      <joint name="j2" type="revolute"><parent link="waist"/><child link="upper"/>
        <origin xyz="0 0 0.4"/><axis xyz="0 -1 0"/>{LIMIT}</joint>
      <joint name="j3" type="revolute"><parent link="upper"/><child link="fore"/>
        <origin xyz="0.6 0 0"/><axis xyz="0 -1 0"/>{LIMIT}</joint></robot>"""
    ans = _answer(urdf)
    r2 = l2 * sp.cos(q2)
    r3 = l2 * sp.cos(q2) + l3 * sp.cos(q2 + q3)
    M = [
        [i1 + m2 * r2**2 + m3 * r3**2, 0, 0],
        [
            0,
            m2 * l2**2 + m3 * (l2**2 + l3**2 + 2 * l2 * l3 * sp.cos(q3)),
            m3 * (l3**2 + l2 * l3 * sp.cos(q3)),
        ],
        [0, m3 * (l3**2 + l2 * l3 * sp.cos(q3)), m3 * l3**2],
    ]
    g = [
        0,
        G0 * (m2 * l2 * sp.cos(q2) + m3 * (l2 * sp.cos(q2) + l3 * sp.cos(q2 + q3))),
        G0 * m3 * l3 * sp.cos(q2 + q3),
    ]
    _assert_equal(_parse(ans["mass_matrix"]["expressions"]), M)
    _assert_equal(_parse(ans["gravity"]["expressions"]), g)
    U = G0 * (m2 * (d1 + l2 * sp.sin(q2)) + m3 * (d1 + l2 * sp.sin(q2) + l3 * sp.sin(q2 + q3)))
    _assert_equal(_parse(ans["potential_energy"]["expressions"]), U)
    # C from the closed-form M by the Christoffel formula, independently of the service's
    qs, dqs = [q1, q2, q3], [dq1, dq2, dq3]
    C = [
        [
            sum(
                R(1, 2)
                * (sp.diff(M[i][j], qs[k]) + sp.diff(M[i][k], qs[j]) - sp.diff(M[j][k], qs[i]))
                * dqs[k]
                for k in range(3)
            )
            for j in range(3)
        ]
        for i in range(3)
    ]
    _assert_equal(_parse(ans["coriolis_matrix"]["expressions"]), C)
    structure = ans["structure"]
    assert [[e["zero"] for e in row] for row in structure["mass_matrix"]] == [
        [False, True, True],
        [True, False, False],
        [True, False, False],
    ]
    assert structure["mass_matrix"][0][0]["depends_on"] == ["q2", "q3"]
    assert structure["gravity"][0] == {"depends_on": [], "constant": True, "zero": True}
