"""Contact sets: a request's contacts as Pinocchio `RigidConstraintModel`s, cached, and checked.

A contact names a frame of the model and a kind:
- `point`: the frame's origin does not move; 3 constraint rows, Pinocchio's CONTACT_3D: the
  classical linear acceleration of the origin is zero;
- `6d`: the frame does not move nor turn; 6 rows, CONTACT_6D: its spatial acceleration (in its
  LOCAL frame) is zero.
Both are built with `reference_frame = LOCAL_WORLD_ALIGNED`, so the constraint Jacobian Jc
(m×nv) is the stack of the frames' LOCAL_WORLD_ALIGNED Jacobians (the 3 linear rows for a
point contact, all 6 for a 6d one) and the contact forces λ (m) are expressed at each frame's
origin with the world's axes: [fx, fy, fz] in N for a point contact, [fx, fy, fz, τx, τy, τz]
in N and N·m for a 6d one, concatenated in the order of the contacts (Pinocchio's `lambda_c`).

A contact set's values (1 to 64 contacts, each a frame name and a kind) are checked here and
only here (`contact_key`), so scripts and the service get the same errors; a frame name shared
by a joint and a link means the link's body frame (`frame_id`), on every route.

The constraint models depend only on the robot and the contact set, so they are built once
and cached (`constraint_models`); the matching `RigidConstraintData` and the `pin.Data` belong
to one computation (`ContactWorkspace`).

Singularity. Pinocchio factors the KKT matrix [[−μ I, Jc], [Jcᵀ, M]] (`constraint_chol`);
its first m pivots are those of −(Jc M⁻¹ Jcᵀ + μ I), the Delassus matrix A of the contacts
(1/kg on force rows, 1/(kg·m²) on torque rows). A contact set is singular — Jc rank-deficient,
e.g. two contacts at one point, two 6d contacts on a 6-joint arm — when a pivot is not finite
or the smallest pivot magnitude is at most `SINGULAR_PIVOT` times the largest. For a symmetric
positive definite A the pivots lie within [σ_min(A), σ_max(A)], so a refused set has a
condition number of at least 1/SINGULAR_PIVOT = 1e8; an exactly rank-deficient Jc gives a zero
(or NaN) pivot. A contact on a frame that no joint moves (attached to the world, e.g. the base
link of a fixed-base arm) is refused before any computation.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from service.dynamics.contacts.solve import proximal_settings
from service.dynamics.frames import frame_id
from service.errors import InvalidInput, SingularConfiguration
from service.registry.robot import Robot

KINDS: dict[str, tuple[Any, int]] = {
    "point": (pin.ContactType.CONTACT_3D, 3),
    "6d": (pin.ContactType.CONTACT_6D, 6),
}
SINGULAR_PIVOT = 1e-8
MAX_CONTACTS = 64  # contacts in one set
MAX_FRAME_NAME = 256  # characters of a contact's frame name
_CACHE_SIZE = 256

ContactKey = tuple[tuple[str, str], ...]


def contact_key(contacts: Sequence[Mapping[str, Any]]) -> ContactKey:
    """The hashable (frame, type) tuple of a request's `contacts` list; the one check of a
    contact set's values (`InvalidInput`): 1 to MAX_CONTACTS contacts, each a mapping with a
    `frame` name of 1 to 256 characters and a `type` of KINDS (default "point")."""
    usage = '[{"frame": "<frame name>", "type": "point" | "6d"}, ...]'
    if isinstance(contacts, str | bytes) or not isinstance(contacts, Sequence) or not contacts:
        raise InvalidInput(f"contacts must name at least one contact: {usage}")
    if len(contacts) > MAX_CONTACTS:
        raise InvalidInput(
            f"contacts has {len(contacts)} contacts; a contact set has at most {MAX_CONTACTS}"
        )
    key = []
    for i, c in enumerate(contacts):
        if not isinstance(c, Mapping):
            raise InvalidInput(f"contacts[{i}] must be an object: {usage}")
        frame, kind = c.get("frame"), c.get("type", "point")
        if not isinstance(frame, str) or not 1 <= len(frame) <= MAX_FRAME_NAME:
            raise InvalidInput(
                f"contacts[{i}].frame must be a frame name of 1 to {MAX_FRAME_NAME} characters"
            )
        if not isinstance(kind, str) or kind not in KINDS:
            raise InvalidInput(f"contacts[{i}].type is 'point' or '6d', not {str(kind)[:20]!r}")
        key.append((frame, kind))
    return tuple(key)


def constraint_rows(contacts: Sequence[Mapping[str, Any]]) -> int:
    """m, the constraint rows of a contact set: 3 per point contact, 6 per 6d one."""
    return sum(KINDS[kind][1] for _, kind in contact_key(contacts))


def describe(key: ContactKey) -> str:
    """`FL_FOOT (point), RF_FOOT (point)`: the contacts as a user wrote them."""
    return ", ".join(f"'{frame}' ({kind})" for frame, kind in key)


class ContactSet:
    """The constraint models of one (robot, contact set); immutable once built."""

    def __init__(self, robot: Robot, key: ContactKey) -> None:
        model = robot.model
        self.key = key
        self.models = pin.StdVec_RigidConstraintModel()
        self.rows: list[slice] = []  # rows of each contact in λ and Jc
        self.frames: list[int] = []  # each contact's frame (`frame_id`'s rule, as every route)
        start = 0
        for i, (frame, kind) in enumerate(key):
            fid = frame_id(robot, frame, f"contacts[{i}].frame")
            self.frames.append(fid)
            f = model.frames[fid]
            if f.parentJoint == 0:
                raise SingularConfiguration(
                    f"contact {i} on frame '{frame}' cannot act: the frame is attached to the "
                    "world (no joint moves it), so its constraint is empty; choose a frame on "
                    "a moving body (the robot's suggested feet are `contact_frames` in "
                    f"GET /v1/robots/{robot.id})",
                    contacts=[frame for frame, _ in key],
                    contact=i,
                )
            contact_type, size = KINDS[kind]
            cm = pin.RigidConstraintModel(
                contact_type,
                model,
                f.parentJoint,
                f.placement,
                pin.ReferenceFrame.LOCAL_WORLD_ALIGNED,
            )
            cm.name = f"{i}:{frame}"
            self.models.append(cm)
            self.rows.append(slice(start, start + size))
            start += size
        self.size = start  # m, the number of constraint rows

    def workspace(self, robot: Robot, data: Any) -> ContactWorkspace:
        return ContactWorkspace(self, robot, data)

    def frame_jacobian(self, robot: Robot, data: Any, q: np.ndarray) -> np.ndarray:
        """Jc (m×nv) at q from the frames' LOCAL_WORLD_ALIGNED Jacobians (3 linear rows for a
        point contact, 6 for a 6d one), without a constrained solve; uses `data`."""
        model = robot.model
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        return np.vstack(
            [
                np.asarray(pin.getFrameJacobian(model, data, fid, lwa)).reshape(6, robot.nv)[
                    : rows.stop - rows.start
                ]
                for fid, rows in zip(self.frames, self.rows, strict=True)
            ]
        )

    @property
    def names(self) -> list[str]:
        return [frame for frame, _ in self.key]

    def pivots(self, data: Any) -> np.ndarray:
        """The m constraint pivots of the factorization just computed in `data` (by
        constraintDynamics or impulseDynamics)."""
        return np.asarray(data.constraint_chol.D)[: self.size]

    def check(self, robot: Robot, data: Any, state: int | None, damping: float) -> None:
        """Raise `SingularConfiguration` if the factorization just computed in `data` shows a
        rank-deficient Jc (see the module)."""
        self.check_all(
            robot,
            self.pivots(data)[np.newaxis],
            state is not None,
            damping,
            0 if state is None else state,
        )

    def check_all(
        self, robot: Robot, pivots: np.ndarray, batched: bool, damping: float, first: int = 0
    ) -> None:
        """The test of `check` for the pivots (N, m) of N states at once; the error names
        the first singular state (numbered from `first`) when `batched`."""
        p = np.abs(pivots)
        with np.errstate(invalid="ignore"):
            ok = p.min(axis=1) > SINGULAR_PIVOT * p.max(axis=1)  # False for NaN
        if ok.all():
            return
        i = int(np.flatnonzero(~ok)[0])
        raise singular(self.key, robot, p[i], first + i if batched else None, damping)


def singular(
    key: ContactKey, robot: Robot, pivots: np.ndarray, state: int | None, damping: float
) -> SingularConfiguration:
    """The 422 for a rank-deficient contact Jacobian, naming the contacts."""
    where = f"state {state}: " if state is not None else ""
    finite_pivots = pivots[np.isfinite(pivots)]
    ratio = (
        float(finite_pivots.min() / finite_pivots.max())
        if finite_pivots.size == pivots.size and pivots.max() > 0
        else 0.0
    )
    fix = (
        'give "damping": μ > 0 to use the regularized (proximal) solution'
        if damping == 0
        else f'"damping" {damping:g} is too small to regularize it; use a larger μ'
    )
    extra = {"state": state} if state is not None else {}
    return SingularConfiguration(
        f"{where}the contact Jacobian Jc of the contacts {describe(key)} is rank-deficient "
        f"here (smallest/largest pivot of Jc M⁻¹ Jcᵀ: {ratio:.3g}; robodyn treats at most "
        f"{SINGULAR_PIVOT:g} as singular): some contact adds no independent constraint (two "
        "contacts at one point, more 6d contacts than the joints can hold, or a direction "
        f"the joints cannot move the frame in); {fix}",
        contacts=[frame for frame, _ in key],
        **extra,
    )


class ContactWorkspace:
    """The per-computation side of a contact set: its `RigidConstraintData` and a `pin.Data`
    prepared by `initConstraintDynamics`. Never shared between threads."""

    def __init__(self, contact_set: ContactSet, robot: Robot, data: Any) -> None:
        self.set = contact_set
        self.model = robot.model
        self.data = data
        self.datas = pin.StdVec_RigidConstraintData()
        for cm in contact_set.models:
            self.datas.append(cm.createData())
        pin.initConstraintDynamics(self.model, data, contact_set.models, self.datas)

    @staticmethod
    def settings(damping: float) -> Any:
        """Pinocchio's proximal settings (`service.dynamics.contacts.solve`)."""
        return proximal_settings(damping)

    def jacobian(self) -> np.ndarray:
        """Jc (m×nv) at the configuration of the last call (LOCAL_WORLD_ALIGNED rows)."""
        return np.array(
            pin.getConstraintsJacobian(self.model, self.data, self.set.models, self.datas)
        )


_lock = threading.Lock()
_cache: OrderedDict[tuple[int, str, ContactKey], tuple[Any, ContactSet]] = OrderedDict()


def constraint_models(robot: Robot, contacts: Sequence[Mapping[str, Any]]) -> ContactSet:
    """The cached `ContactSet` of `contacts` on `robot` (built on first use; least recently
    used sets beyond 256 are dropped). Unknown frames are `UnknownFrame`, world-attached
    frames `SingularConfiguration`; neither is cached."""
    key = contact_key(contacts)
    cache_key = (id(robot.model), robot.id, key)
    with _lock:
        hit = _cache.get(cache_key)
        if hit is not None and hit[0] is robot.model:
            _cache.move_to_end(cache_key)
            return hit[1]
    built = ContactSet(robot, key)
    with _lock:
        _cache[cache_key] = (robot.model, built)  # holding the model keeps id() unique
        _cache.move_to_end(cache_key)
        while len(_cache) > _CACHE_SIZE:
            _cache.popitem(last=False)
    return built
