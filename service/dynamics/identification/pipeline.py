"""Identification of a fixed-base robot's inertial parameters and friction from a logged motion.

    identify(robot, t, q, tau, v=None, a=None, friction="coulomb-viscous",
             method="physically-consistent", validation_fraction=0.2, filter_hz=None,
             payload_frame=None, weighted=True) → Identification

1. The log is checked, split (the last `validation_fraction` by time is held out) and, when
   v or a is missing, resampled, filtered and differentiated (`motion_log`); a log in which
   every joint barely moves is refused (`check_motion`).
2. The base parameters of the columns (`columns`: the robot, or a payload at a frame) come
   from random states (`base_parameters`); only their columns are evaluated on the log.
3. The columns and the known torques are filtered like τ (parallel filtering), the edge
   margins dropped, the training part decimated, and θ fitted (`fit`): weighted least squares
   (method "least-squares"; ordinary with `weighted` False) or the semidefinite program with
   every body's pseudo-inertia ⪰ 0 (method "physically-consistent").
4. RMSE per joint (N·m or N) between the measured torques (filtered like the columns) and the
   model's, on every kept sample: `train`, `validation` (the fitted model), `validation_before`
   (the model's own parameters, without friction; for a payload, without the payload).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from service.dynamics.identification.base_parameters import (
    BaseParameters,
    base_parameters,
    random_states_count,
)
from service.dynamics.identification.columns import Columns
from service.dynamics.identification.fit import CONSISTENCY_TOLERANCE, Fit, fit, prior_scale
from service.dynamics.identification.motion_log import (
    DEFAULT_VALIDATION_FRACTION,
    LowPass,
    MotionLog,
    Part,
    barely_moving,
    check_motion,
    describe_ranges,
    joint_configurations,
    motion_log,
    unexcited_joints,
)
from service.dynamics.identification.parameters import (
    PER_BODY,
    body_names,
    body_summary,
    pseudo_inertia_min_eigenvalues,
)
from service.dynamics.identification.regressor import DEFAULT_FRICTION, friction_terms
from service.errors import InvalidInput, NonFiniteResult
from service.registry.robot import Robot

METHODS = ("least-squares", "physically-consistent")
STAGES = ("log", "base parameters", "regressor", "fit", "validation")
"""The steps of `identify`, in order, as its progress names them."""
Progress = Callable[[int, int, str, str], object]
"""`progress(done, total, unit, stage)`: `done` of `total` stages are done, `stage` runs."""
DEFAULT_METHOD = "physically-consistent"
PAYLOAD_SCALE = np.array([10.0, 1.0, 1.0, 1.0] + [0.1] * 6)  # kg, kg·m, kg·m²: a weak prior
FILTER_COLUMNS = 256  # columns filtered at a time (bounds the filter's temporary memory)


@dataclass(frozen=True)
class Identification:
    """The answer of `identify` (numbers in SI units, arrays as numpy)."""

    parameters: np.ndarray  # π (10 · bodies,) of the identified robot
    bodies: list[dict[str, Any]]  # `parameters.body_summary` of each body
    friction: list[dict[str, Any] | None]  # {"joint", "coulomb", "viscous", "offset"}; None:
    # a joint whose motion does not determine its friction (`warnings`)
    base_parameters: dict[str, Any]  # {"expressions", "values", "standard_deviation"}
    condition_number: float
    physically_consistent: bool
    rmse: dict[str, np.ndarray]  # "train", "validation", "validation_before": (nv,) each
    payload: dict[str, Any] | None  # {"mass", "center_of_mass", "inertia"} in the frame
    validation: dict[str, np.ndarray]  # "t", "measured", "predicted", "before" on kept samples
    filter_hz: float | None  # the cut-off used; None when the log was used as given
    samples: dict[str, int]  # "train" and "validation" kept, "fit" (after decimation)
    warnings: list[dict[str, str]]  # {"code": "unexcited_joint", "joint", "detail"}
    # what the base parameters' estimates are worth, for a variant to keep (`uncertainty`)
    uncertainty: dict[str, Any] | None = None


def random_rows(robot: Robot, columns: Columns) -> Any:
    """The random-state stack of `columns` for `base_parameters`: q uniform within the
    joints' finite limits (±π elsewhere), v and a standard normal."""
    model = robot.model
    lower, upper = np.full(robot.nv, -math.pi), np.full(robot.nv, math.pi)
    for jid in range(1, model.njoints):
        joint = model.joints[jid]
        if joint.nq == 1:
            lo, hi = model.lowerPositionLimit[joint.idx_q], model.upperPositionLimit[joint.idx_q]
            if math.isfinite(lo) and math.isfinite(hi) and hi > lo:
                lower[joint.idx_v], upper[joint.idx_v] = lo, hi

    def rows(rng: np.random.Generator, count: int) -> np.ndarray:
        x = rng.uniform(lower, upper, size=(count, robot.nv))
        v, a = rng.standard_normal((2, count, robot.nv))
        return columns(joint_configurations(robot, x), v, a)[0].reshape(-1, len(columns.names))

    return rows


def _filtered(lowpass: LowPass | None, x: np.ndarray) -> np.ndarray:
    if lowpass is None:
        return x
    flat = x.reshape(x.shape[0], -1)
    out = np.empty_like(flat)
    for start in range(0, flat.shape[1], FILTER_COLUMNS):
        cols = slice(start, start + FILTER_COLUMNS)
        out[:, cols] = lowpass(flat[:, cols])
    return out.reshape(x.shape)


def _rows(
    part: Part, columns: Columns, base: BaseParameters, lowpass: LowPass | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A (n, nv, r), known (n, nv), measured τ (n, nv)) on the kept samples of a part."""
    if part.t.size == 0:
        return (
            np.zeros((0, part.tau.shape[1], base.count)),
            np.zeros((0, part.tau.shape[1])),
            np.zeros((0, part.tau.shape[1])),
        )
    A, known = columns(part.q, part.v, part.a, base.independent)
    with np.errstate(over="ignore", invalid="ignore"):  # (checked: `_require_fittable`)
        A, known = _filtered(lowpass, A)[part.keep], _filtered(lowpass, known)[part.keep]
    return A, known, part.tau[part.keep]


def _rmse(error: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(error**2, axis=0)) if error.size else np.full(error.shape[1], np.nan)


def _required_samples(log: MotionLog, needed_fit: int, fraction: float) -> float:
    """About how many log samples at this log's rate give `needed_fit` fit samples (a whole
    number, or inf when a tiny validation fraction needs more than float64 counts)."""
    margin = 0 if log.lowpass is None else log.lowpass.margin
    train = needed_fit * log.decimation + 2 * margin
    with np.errstate(over="ignore"):
        needed = max(train / (1.0 - fraction), float(np.float64(2 * margin + 1) / fraction))
    return float(math.ceil(needed)) if math.isfinite(needed) else math.inf


def _count(n: float) -> str:
    """A whole number n in full below a billion, else in 3 significant digits."""
    return str(int(n)) if n < 1_000_000_000 else f"{n:.3g}"


def _stages(progress: Progress | None) -> Callable[[str], None]:
    """`stage(name)`: tell `progress` that the stages before `name` are done."""

    def stage(name: str) -> None:
        if progress is not None:
            progress(STAGES.index(name), len(STAGES), "stage", name)

    return stage


def identify(
    robot: Robot,
    t: Any,
    q: Any,
    tau: Any,
    v: Any = None,
    a: Any = None,
    friction: str = DEFAULT_FRICTION,
    method: str = DEFAULT_METHOD,
    validation_fraction: float = DEFAULT_VALIDATION_FRACTION,
    filter_hz: float | None = None,
    payload_frame: str | None = None,
    weighted: bool = True,
    progress: Progress | None = None,
) -> Identification:
    """Identify the robot (or a payload at `payload_frame`) from a log: see the module
    docstring; t (N,) s, q (N, nq), tau (N, nv) measured, v, a (N, nv) optional.
    `progress(done, total, "stage", name)` (optional) is told as each of the STAGES after the
    first starts (the log is checked first: a log refused says so before any progress)."""
    stage = _stages(progress)
    terms = friction_terms(friction)
    if method not in METHODS:
        raise InvalidInput(f"method must be one of {', '.join(repr(m) for m in METHODS)}")
    log = motion_log(robot, t, q, tau, v, a, filter_hz, validation_fraction)
    check_motion(robot, log)
    columns = Columns(robot, friction, payload_frame)
    stage("base parameters")
    base = base_parameters(
        random_rows(robot, columns),
        columns.names,
        random_states_count(len(columns.names), robot.nv),
    )
    stage("regressor")
    A, known, measured = _rows(log.train, columns, base, log.lowpass)
    needed = math.ceil(2 * base.count / robot.nv) + 1
    fit_rows = slice(None, None, log.decimation)
    val_A, val_known, val_measured = _rows(log.validation, columns, base, log.lowpass)
    if A[fit_rows].shape[0] < needed or val_A.shape[0] < 1:
        raise InvalidInput(
            f"the log has {np.size(t)} samples; identifying {base.count} base parameters of "
            f"robot '{robot.id}' (friction '{friction}') needs at least "
            f"{_count(_required_samples(log, needed, validation_fraction))} at this sample rate: "
            f"{needed} fit samples in the training part"
            + (
                ""
                if log.lowpass is None
                else " after dropping "
                f"{log.lowpass.margin / log.lowpass.sample_rate:.3g} s at both "
                "ends of each part and "
                f"keeping one sample in {log.decimation} (filter at {log.lowpass.cutoff_hz:.3g} "
                "Hz)"
            )
            + ", and at least one in the validation part"
        )
    scale = (
        prior_scale(
            columns.theta0[: columns.inertial_count], len(columns.names) - columns.inertial_count
        )
        if payload_frame is None
        else np.concatenate(
            [PAYLOAD_SCALE, prior_scale(np.zeros(0), len(columns.names) - PER_BODY)]
        )
    )
    with np.errstate(over="ignore", invalid="ignore"):
        b = measured - known
    _require_fittable(log, A, b, val_A, val_known, val_measured)
    still = barely_moving(robot, log)
    stage("fit")
    try:
        result = fit(
            A[fit_rows],
            b[fit_rows],
            base,
            columns.theta0,
            scale,
            columns.bodies,
            method == "physically-consistent",
            weighted,
            still=describe_ranges(robot, still),
        )
    except np.linalg.LinAlgError:
        raise InvalidInput(
            "identify: the fit's linear algebra failed on this log's numbers "
            f"({_peaks(log)}): are they extreme?"
        ) from None
    stage("validation")
    answer = _answer(
        robot,
        columns,
        base,
        result,
        log,
        terms,
        (A, known, measured),
        (val_A, val_known, val_measured),
        unexcited_joints(robot, log),
    )
    numbers = [answer.parameters, result.beta, result.beta_std, *answer.rmse.values()]
    if not all(np.isfinite(x).all() for x in numbers):
        raise NonFiniteResult(
            "identify: the fit is not finite for this log (are its torques or positions extreme?)"
        )
    return answer


def _peaks(log: MotionLog) -> str:
    """ "|q| up to 1e+300, |v| up to …" over the log's parts, in SI units."""
    parts = [p for p in (log.train, log.validation) if p.t.size]

    def peak(name: str) -> float:
        return max((float(np.abs(getattr(p, name)).max()) for p in parts), default=0.0)

    return (
        f"|q| up to {peak('q'):.3g}, |v| up to {peak('v'):.3g}, |a| up to {peak('a'):.3g}, "
        f"|tau| up to {peak('tau'):.3g}; SI units: rad or m, /s, /s², N·m or N"
    )


def _require_fittable(log: MotionLog, *arrays: np.ndarray) -> None:
    """InvalidInput naming the log's largest numbers when the sum of the squares of one of
    `arrays` (the regressor columns, whose entries are products of the velocities and of the
    accelerations, and the torques) is not finite: the fit sums such squares."""
    with np.errstate(over="ignore", invalid="ignore"):
        fittable = all(np.isfinite(np.sum(np.square(x))) for x in arrays)
    if not fittable:
        raise InvalidInput(
            "identify: this log's numbers are too large to fit in float64 (the fit sums the "
            "squares of its regressor, products of velocities and accelerations, and of its "
            f"torques): {_peaks(log)}. Are they extreme?"
        )


def _answer(
    robot: Robot,
    columns: Columns,
    base: BaseParameters,
    result: Fit,
    log: MotionLog,
    terms: tuple[str, ...],
    train: tuple[np.ndarray, ...],
    validation: tuple[np.ndarray, ...],
    unexcited: dict[str, str],
) -> Identification:
    beta0 = base.projection() @ columns.theta0
    predicted_train = train[0] @ result.beta + train[1]
    predicted = validation[0] @ result.beta + validation[1]
    before = validation[0] @ beta0 + validation[1]
    pi = columns.robot_parameters(result.theta)
    names = body_names(robot.model)
    bodies = [
        body_summary(name, pi[PER_BODY * i : PER_BODY * (i + 1)]) for i, name in enumerate(names)
    ]
    fitted = result.theta[columns.inertial_count :].reshape(robot.nv, len(terms))
    friction: list[dict[str, Any] | None] = [
        None
        if joint in unexcited
        else {
            "joint": joint,
            "coulomb": 0.0,
            "viscous": 0.0,
            "offset": 0.0,
            **{term: float(fitted[j, k]) for k, term in enumerate(terms)},
        }
        for j, joint in enumerate(names)
    ]
    payload = None
    own = result.theta[: PER_BODY * columns.bodies]
    if columns.payload_frame is not None:
        summary = body_summary("payload", result.theta[:PER_BODY])
        payload = {
            "frame": columns.payload_frame,
            "mass": summary["mass"],
            "center_of_mass": summary["center_of_mass"],
            "inertia": summary["inertia"],
        }
    consistent = bool((pseudo_inertia_min_eigenvalues(own) >= -CONSISTENCY_TOLERANCE).all())
    valid_t = log.validation.t[log.validation.keep]
    return Identification(
        parameters=pi,
        bodies=bodies,
        friction=friction,
        base_parameters={
            "expressions": base.expressions(),
            "values": result.beta,
            "standard_deviation": result.beta_std,
        },
        condition_number=result.condition_number,
        physically_consistent=consistent,
        rmse={
            "train": _rmse(predicted_train - train[2]),
            "validation": _rmse(predicted - validation[2]),
            "validation_before": _rmse(before - validation[2]),
        },
        payload=payload,
        validation={
            "t": valid_t,
            "measured": validation[2],
            "predicted": predicted,
            "before": before,
        },
        filter_hz=None if log.lowpass is None else log.lowpass.cutoff_hz,
        samples={
            "train": int(train[0].shape[0]),
            "validation": int(validation[0].shape[0]),
            "fit": int(train[0][:: log.decimation].shape[0]),
        },
        warnings=[
            {"code": "unexcited_joint", "joint": joint, "detail": detail}
            for joint, detail in unexcited.items()
        ],
        uncertainty=None if columns.payload_frame is not None else uncertainty(base, result),
    )


def uncertainty(base: BaseParameters, result: Fit) -> dict[str, Any]:
    """What a variant keeps of a robot's identification to give the standard deviation of
    any combination c·θ of its parameters: `names` (θ's, friction last), `projection` P
    (r × len(θ), β = P θ), `covariance` of β (r × r; its diagonal the base parameters'
    `standard_deviation` squared) and `determined` (r × k, columns spanning the functionals
    of β the log determines: `fit.determined_directions`). Plain lists (JSON)."""
    return {
        "names": list(base.names),
        "projection": base.projection().tolist(),
        "covariance": np.asarray(result.beta_covariance).tolist(),
        "determined": np.asarray(result.determined).tolist(),
    }
