"""M(q) and the potential energy U(q) in exact trigonometric polynomials.

M is assembled as Σᵢ Jᵢᵀ 𝕀ᵢ Jᵢ (the kinetic energy T = ½ Σ (m vᵀv + ωᵀ I ω) of the bodies,
T = ½ q̇ᵀ M q̇) the way the composite-rigid-body algorithm does it, but on `Series` instead of
floats. Frames: frame j is joint j's frame after its motion (the body it carries is described
there); parentMj(q_j) = placement_j · motion_j(q_j) with, for a revolute joint of unit axis a,
R(q) = cos q · 1 + sin q · [a]× + (1 − cos q) a aᵀ, and for a prismatic one a translation a q.

1. Composite inertias, leaves to root: each body is (m, h = m c, I_O) — its mass, first moment
   and rotational inertia about the frame origin. A child's composite moves into its parent's
   frame by (R, p): h' = R h + m p, I_O' = R I_O Rᵀ − [p]×[Rh]× − [Rh]×[p]× − m [p]×[p]×.
2. Column j of M: the composite's momentum for a unit joint velocity, F = 𝕀ᶜⱼ Sⱼ (revolute,
   S = (0, a): f = a × h, n = I_O a; prismatic, S = (a, 0): f = m a, n = h × a), then M_jj =
   Sⱼᵀ F plus the armature, and for each ancestor i, with F carried up one frame at a time
   (f' = R f, n' = R n + p × f'), M_ij = Sᵢᵀ F. Non-ancestor pairs have M_ij = 0.
3. The world first moment H = Σ m c of all bodies is the root composites' h carried into the
   world frame, and U(q) = −g₀ · H (zero at the world origin, as Pinocchio's
   computePotentialEnergy).

M_ij (i ≤ j) then depends on q_{i+1} … only, never on q_i or the coordinates above it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from decimal import Decimal, localcontext

from service.dynamics.equations.model_numbers import Joint, Mat3, Vec3
from service.dynamics.equations.series import COS, PRECISION, SIN, Series
from service.errors import UnsupportedModel

# What that rounding leaves where terms cancel: a composite's terms below this fraction of its
# largest coefficient are dropped as they are formed (they are 1e-40-relative residues).
ROUNDING_RESIDUE = Decimal("1e-30")

SVec = list[Series]
SMat = list[list[Series]]

Check = Callable[[], None]


def deadline_check(deadline: float | None, limit_s: float | None) -> Check:
    """A function raising `UnsupportedModel` once `time.monotonic()` passes `deadline`."""

    def check() -> None:
        if deadline is not None and time.monotonic() > deadline:
            raise UnsupportedModel(
                f"the derivation of the equations did not finish within its time limit of "
                f"{limit_s:g} s; the model is too large for the explicit form"
            )

    return check


def _const(n: int, x: Decimal) -> Series:
    return Series.constant(n, x)


def _cvec(n: int, v: Vec3) -> SVec:
    return [_const(n, x) for x in v]


def _cmat(n: int, m: Mat3) -> SMat:
    return [[_const(n, x) for x in row] for row in m]


def _matmul(a: SMat, b: SMat, n: int) -> SMat:
    out: SMat = []
    for r in range(3):
        row = []
        for c in range(3):
            acc = Series(n)
            for k in range(3):
                if a[r][k].terms and b[k][c].terms:
                    acc = acc + a[r][k] * b[k][c]
            row.append(acc)
        out.append(row)
    return out


def _matvec(a: SMat, v: SVec, n: int) -> SVec:
    out = []
    for r in range(3):
        acc = Series(n)
        for k in range(3):
            if a[r][k].terms and v[k].terms:
                acc = acc + a[r][k] * v[k]
        out.append(acc)
    return out


def _transpose(a: SMat) -> SMat:
    return [[a[c][r] for c in range(3)] for r in range(3)]


def _cross(a: SVec, b: SVec) -> SVec:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _dot(a: SVec, b: SVec, n: int) -> Series:
    acc = Series(n)
    for x, y in zip(a, b, strict=True):
        if x.terms and y.terms:
            acc = acc + x * y
    return acc


def joint_motion(joint: Joint, i: int, n: int) -> tuple[SMat, SVec]:
    """(R(q_i), p(q_i)) of joint i's motion: Rodrigues' rotation cos q 1 + sin q [a]× +
    (1 − cos q) a aᵀ for a revolute joint, the translation a q_i for a prismatic one."""
    a = joint.axis
    zero = Series(n)
    if joint.kind == "prismatic":
        identity = [[_const(n, Decimal(int(r == c))) for c in range(3)] for r in range(3)]
        qi = Series.variable(n, i)
        return identity, [qi.scale(x) for x in a]
    cos, sin = Series.trig(n, i, COS), Series.trig(n, i, SIN)
    skew = ((0, -a[2], a[1]), (a[2], 0, -a[0]), (-a[1], a[0], 0))
    rot: SMat = []
    for r in range(3):
        row = []
        for c in range(3):
            outer = a[r] * a[c]
            entry = _const(n, outer) + cos.scale(Decimal(int(r == c)) - outer)
            row.append(entry + sin.scale(Decimal(skew[r][c])))
        rot.append(row)
    return rot, [zero, zero, zero]


def parent_placement(joint: Joint, i: int, n: int) -> tuple[SMat, SVec]:
    """parentMj(q) = placement · motion(q): (R_pl R(q), p_pl + R_pl p(q))."""
    rot_q, p_q = joint_motion(joint, i, n)
    placement = _cmat(n, joint.rotation)
    rot = _matmul(placement, rot_q, n)
    p = _cvec(n, joint.translation)
    if joint.kind == "prismatic":
        moved = _matvec(placement, p_q, n)
        p = [x + y for x, y in zip(p, moved, strict=True)]
    return rot, p


def body_inertia(joint: Joint, n: int) -> tuple[Decimal, SVec, SMat]:
    """(m, h = m c, I_O = I_c + m (|c|² 1 − c cᵀ)) of the body joint `joint` carries."""
    m, c, ic = joint.mass, joint.lever, joint.inertia
    c2 = sum((x * x for x in c), Decimal(0))
    io = [
        [ic[r][k] + m * ((c2 if r == k else 0) - c[r] * c[k]) for k in range(3)] for r in range(3)
    ]
    return m, [_const(n, m * x) for x in c], [[_const(n, x) for x in row] for row in io]


def move_inertia(m: Decimal, h: SVec, io: SMat, rot: SMat, p: SVec, n: int) -> tuple[SVec, SMat]:
    """A body's (h, I_O) in the parent frame, the body frame being at (rot, p) there:
    h' = R h + m p, I_O' = R I_O Rᵀ − [p]×[Rh]× − [Rh]×[p]× − m [p]×[p]×, with
    [a]×[b]× = b aᵀ − (a·b) 1."""
    rh = _matvec(rot, h, n)
    h2 = [x + y.scale(m) for x, y in zip(rh, p, strict=True)]
    rot_io = _matmul(rot, io, n)
    rt = _transpose(rot)
    p_rh = _dot(p, rh, n)
    p_p = _dot(p, p, n)
    io2: SMat = [[Series(n)] * 3 for _ in range(3)]
    for r in range(3):
        for c in range(r, 3):
            acc = Series(n)
            for k in range(3):
                if rot_io[r][k].terms and rt[k][c].terms:
                    acc = acc + rot_io[r][k] * rt[k][c]
            # −[p]×[Rh]× − [Rh]×[p]× = −(Rh pᵀ + p Rhᵀ) + 2 (p·Rh) 1
            acc = acc - (rh[r] * p[c] + p[r] * rh[c])
            # −m [p]×[p]× = m (|p|² 1 − p pᵀ)
            acc = acc - (p[r] * p[c]).scale(m)
            if r == c:
                acc = acc + p_rh.scale(Decimal(2)) + p_p.scale(m)
            io2[r][c] = acc
            io2[c][r] = acc
    return h2, io2


def mass_matrix_and_potential(
    joints: list[Joint], gravity: Vec3, check: Check
) -> tuple[list[list[Series]], Series]:
    """(M(q) as nv×nv Series, symmetric; U(q)), exact. See the module docstring."""
    with localcontext(prec=PRECISION):
        return _mass_matrix_and_potential(joints, gravity, check)


def _mass_matrix_and_potential(
    joints: list[Joint], gravity: Vec3, check: Check
) -> tuple[list[list[Series]], Series]:
    n = len(joints)
    placements = [parent_placement(j, i, n) for i, j in enumerate(joints)]
    mass = [j.mass for j in joints]
    first = []
    rot_inertia = []
    for body in joints:
        _, h, io = body_inertia(body, n)
        first.append(h)
        rot_inertia.append(io)
    world_h = [Series(n), Series(n), Series(n)]
    for i in range(n - 1, -1, -1):  # children have larger indices than their parents
        check()
        rot, p = placements[i]
        h2, io2 = move_inertia(mass[i], first[i], rot_inertia[i], rot, p, n)
        h2 = _without_residues(h2)
        flat = _without_residues([x for row in io2 for x in row])
        io2 = [flat[0:3], flat[3:6], flat[6:9]]
        parent = joints[i].parent
        if parent < 0:
            world_h = [x + y for x, y in zip(world_h, h2, strict=True)]
            continue
        mass[parent] += mass[i]
        first[parent] = [x + y for x, y in zip(first[parent], h2, strict=True)]
        rot_inertia[parent] = [
            [x + y for x, y in zip(ra, rb, strict=True)]
            for ra, rb in zip(rot_inertia[parent], io2, strict=True)
        ]
    M: list[list[Series]] = [[Series(n) for _ in range(n)] for _ in range(n)]
    for j, joint in enumerate(joints):
        check()
        a = _cvec(n, joint.axis)
        if joint.kind == "revolute":
            f = _cross(a, first[j])
            torque = _matvec(rot_inertia[j], a, n)
        else:
            f = [x.scale(mass[j]) for x in a]
            torque = _cross(first[j], a)
        M[j][j] = _motion_power(joints[j], f, torque, n) + _const(n, joint.armature)
        k = j
        while joints[k].parent >= 0:
            rot, p = placements[k]
            f = _matvec(rot, f, n)
            torque = [x + y for x, y in zip(_matvec(rot, torque, n), _cross(p, f), strict=True)]
            k = joints[k].parent
            M[k][j] = M[j][k] = _motion_power(joints[k], f, torque, n)
    g0 = _cvec(n, gravity)
    return M, -_dot(g0, world_h, n)


def _without_residues(entries: SVec) -> SVec:
    scale = max((s.largest_coefficient() for s in entries), default=Decimal(0))
    bound = scale * ROUNDING_RESIDUE
    return [s.without_terms_below(bound) for s in entries]


def _motion_power(joint: Joint, f: SVec, torque: SVec, n: int) -> Series:
    """Sᵀ F: the joint's axis against the torque (revolute) or the force (prismatic)."""
    a = _cvec(n, joint.axis)
    return _dot(a, torque if joint.kind == "revolute" else f, n)
