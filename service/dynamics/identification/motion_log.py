"""A logged motion, checked and split: (t, q, τ) and optional v, a → training and validation parts.

- **Checks.** t (N,) in s, strictly increasing; q (N, nq); τ (N, nv) measured, N·m or N;
  v, a (N, nv) optional; every number finite. Identification needs a fixed-base robot whose
  joints are 1-DoF (revolute, prismatic or continuous): anything else is `UnsupportedModel`.
- **Split.** The last `validation_fraction` of the log by time (default 0.2) is held out; the
  two parts are filtered separately, so no sample of one leaks into the other.
- **Filter.** When v or a is missing (or `filter_hz` is given), each part is resampled on a
  uniform grid (the log's median interval; linear interpolation, so irregular sampling is
  fine), q, τ and any given v, a are low-pass filtered forwards and backwards (zero phase:
  a Butterworth filter of order FILTER_ORDER, scipy's `sosfiltfilt`, cut-off `filter_hz`,
  default DEFAULT_FILTER_HZ or a fifth of the sample rate if that is lower), and the missing
  derivatives are central differences of the filtered signals. The regressor and friction
  columns computed from these are filtered by the same filter again ("parallel filtering":
  filter(τ) = filter(Y) π holds exactly because the filter is linear), so τ and the columns
  see the same filter.
- **Motion.** A log in which every joint barely moves (its coordinate's range over the kept
  samples, filtered when the log is, below MIN_RANGE: MIN_RANGE_REVOLUTE rad or
  MIN_RANGE_PRISMATIC m) reveals only gravity at one configuration, no inertia and no friction:
  `check_motion` refuses it, naming each joint's range, before any fit.
- **Friction.** A joint whose motion does not show its friction — it barely moves (range below
  MIN_RANGE) or its speed stays near zero (|v| below MIN_SPEED: MIN_SPEED_REVOLUTE rad/s or
  MIN_SPEED_PRISMATIC m/s over the kept samples) — is named by `unexcited_joints`: its friction
  columns stay in the fit (its Coulomb switching is in the torques, and leaving them out biases
  every rigid-body parameter), but their values are not reported or stored.
- **Edges.** Zero-phase filtering and differences are wrong near both ends of a signal; a margin
  of MARGIN_PERIODS / filter_hz seconds is dropped at both ends of each part after filtering.
- **Decimation.** Filtered samples are correlated; the fit keeps one every `decimation` of the
  kept samples (spacing about 1 / (DECIMATION_RATE · filter_hz)), so least squares sees about
  independent noise and its standard deviations are honest. Validation RMSEs use every kept
  sample.

Unfiltered logs (v and a given, no `filter_hz`) are used as they are, on their own time grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.signal

from service.errors import DimensionMismatch, InvalidInput, UnsupportedModel
from service.registry.robot import Robot
from service.states import as_array, configurations

DEFAULT_FILTER_HZ = 10.0
FILTER_ORDER = 4
MARGIN_PERIODS = 3.0  # edge margin, in periods of the cut-off frequency
DECIMATION_RATE = 2.0  # fit samples per period of the cut-off: the filtered band's Nyquist rate
DEFAULT_VALIDATION_FRACTION = 0.2
RESAMPLING_GROWTH = 4  # a uniform grid of at most this many times a part's samples (+ 1000)
ONE_DOF = ("revolute", "prismatic", "continuous")
MIN_RANGE_REVOLUTE = 0.02  # rad (about 1.1°): below it a joint "barely moves"
MIN_RANGE_PRISMATIC = 0.005  # m
MIN_SPEED_REVOLUTE = 0.05  # rad/s: a joint whose speed stays below it shows no friction
MIN_SPEED_PRISMATIC = 0.01  # m/s


@dataclass(frozen=True)
class LowPass:
    """The zero-phase low-pass filter of a log (see the module docstring)."""

    cutoff_hz: float
    sample_rate: float  # Hz, of the uniform grid
    sos: np.ndarray

    @property
    def margin(self) -> int:
        """Samples dropped at both ends of each filtered part."""
        return math.ceil(MARGIN_PERIODS * self.sample_rate / self.cutoff_hz)

    @property
    def decimation(self) -> int:
        """Keep one fit sample in this many."""
        return max(1, round(self.sample_rate / (DECIMATION_RATE * self.cutoff_hz)))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """x filtered along its first (time) axis, forwards and backwards."""
        return np.asarray(scipy.signal.sosfiltfilt(self.sos, x, axis=0))


@dataclass(frozen=True)
class Part:
    """One part of the log on its (uniform when filtered) grid: t (n,), q (n, nq) in
    Pinocchio's order, v, a, τ (n, nv); τ already filtered. `keep` selects the samples outside
    the edge margins."""

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    tau: np.ndarray
    keep: slice


@dataclass(frozen=True)
class MotionLog:
    train: Part
    validation: Part
    lowpass: LowPass | None  # None: used as given

    @property
    def decimation(self) -> int:
        return 1 if self.lowpass is None else self.lowpass.decimation


def check_robot(robot: Robot) -> None:
    """`UnsupportedModel` unless every joint is 1-DoF (so the base is fixed)."""
    for name, kind in robot.joint_types.items():
        if kind not in ONE_DOF:
            base = " (a floating base)" if kind in ("free_flyer", "planar") else ""
            raise UnsupportedModel(
                f"identification needs a fixed-base robot whose joints are revolute, prismatic "
                f"or continuous; joint '{name}' of robot '{robot.id}' is {kind}{base}"
            )


def _coordinates(robot: Robot, q: np.ndarray) -> np.ndarray:
    """One coordinate per joint (N, nv): q itself, or for a continuous joint its angle
    atan2(sin, cos), unwrapped along time so that it can be filtered and differentiated."""
    out = np.empty((q.shape[0], robot.nv))
    for jid in range(1, robot.model.njoints):
        joint = robot.model.joints[jid]
        if joint.nq == 2:
            angle = np.arctan2(q[:, joint.idx_q + 1], q[:, joint.idx_q])
            out[:, joint.idx_v] = np.unwrap(angle)
        else:
            out[:, joint.idx_v] = q[:, joint.idx_q]
    return out


def joint_configurations(robot: Robot, x: np.ndarray) -> np.ndarray:
    """The inverse of `_coordinates`: q (N, nq) in Pinocchio's order."""
    out = np.empty((x.shape[0], robot.nq))
    for jid in range(1, robot.model.njoints):
        joint = robot.model.joints[jid]
        if joint.nq == 2:
            out[:, joint.idx_q] = np.cos(x[:, joint.idx_v])
            out[:, joint.idx_q + 1] = np.sin(x[:, joint.idx_v])
        else:
            out[:, joint.idx_q] = x[:, joint.idx_v]
    return out


def _signal(
    name: str, value: Any, rows: int, width: int, width_name: str, robot: Robot
) -> np.ndarray:
    arr = as_array(
        name,
        value,
        "(one entry per sample)" if width == 0 else f"(one row of {width_name} entries per sample)",
    )
    if width == 0:
        if arr.ndim != 1:
            raise InvalidInput(f"{name} must be 1-D (one time per sample)")
        return arr
    if arr.ndim != 2 or arr.shape[1] != width:
        got = arr.shape[1] if arr.ndim == 2 else "1-D"
        raise DimensionMismatch(
            f"each row of {name} must have {width} entries (robot "
            f"'{robot.id}' has {width_name} = {width}); it has {got}"
        )
    if arr.shape[0] != rows:
        raise DimensionMismatch(f"{name} has {arr.shape[0]} rows; t has {rows} samples")
    return arr


def motion_log(
    robot: Robot,
    t: Any,
    q: Any,
    tau: Any,
    v: Any = None,
    a: Any = None,
    filter_hz: float | None = None,
    validation_fraction: float = DEFAULT_VALIDATION_FRACTION,
) -> MotionLog:
    """Check a log and prepare its training and validation parts (see the module docstring).
    q in the API's order (a MuJoCo-qpos robot's quaternions are converted)."""
    check_robot(robot)
    times = _signal("t", t, 0, 0, "", robot)
    if times.size < 4:
        raise InvalidInput(
            f"t has {times.size} samples; identification needs a log of "
            "hundreds of samples at least"
        )
    steps = np.diff(times)
    if not (steps > 0).all():
        i = int(np.flatnonzero(steps <= 0)[0])
        raise InvalidInput(f"t must be strictly increasing; t[{i + 1}] ≤ t[{i}]")
    n = times.size
    positions = configurations(robot, _signal("q", q, n, robot.nq, "nq", robot))
    torques = _signal("tau", tau, n, robot.nv, "nv", robot)
    given = {
        name: _signal(name, value, n, robot.nv, "nv", robot)
        for name, value in (("v", v), ("a", a))
        if value is not None
    }
    if not 0.0 < validation_fraction <= 0.5:
        raise InvalidInput(
            "validation_fraction must be > 0 and ≤ 0.5 (the held-out end of "
            "the log, as a fraction of its duration)"
        )
    lowpass = None
    if filter_hz is not None or len(given) < 2:
        lowpass = _lowpass(steps, filter_hz)
    split = times[0] + (1.0 - validation_fraction) * (times[-1] - times[0])
    train = times < split
    parts = [
        _part(
            robot, times[m], positions[m], torques[m], {k: x[m] for k, x in given.items()}, lowpass
        )
        for m in (train, ~train)
    ]
    return MotionLog(train=parts[0], validation=parts[1], lowpass=lowpass)


def _lowpass(steps: np.ndarray, filter_hz: float | None) -> LowPass:
    interval = float(np.median(steps))
    with np.errstate(divide="ignore", over="ignore"):
        rate = 1.0 / interval
    if not math.isfinite(rate):
        raise InvalidInput(
            f"t: the log's median sample interval, {interval:.3g} s, is too small to filter "
            "with (its sample rate overflows float64)"
        )
    nyquist = 0.5 * rate
    if filter_hz is None:
        cutoff = min(DEFAULT_FILTER_HZ, 0.2 * rate)
    elif not (math.isfinite(filter_hz) and 0.0 < filter_hz < 0.9 * nyquist):
        raise InvalidInput(
            f"filter_hz must be > 0 and below 0.9 × the log's Nyquist "
            f"frequency ({nyquist:.6g} Hz at its median sample rate)"
        )
    else:
        cutoff = float(filter_hz)
    if not cutoff / nyquist > 0.0:  # (the filter's normalized frequency underflows)
        raise InvalidInput(
            f"filter_hz: a cut-off of {cutoff:.3g} Hz is too small for the log's sample rate "
            f"({rate:.6g} Hz) to design a filter in float64"
        )
    sos = scipy.signal.butter(FILTER_ORDER, cutoff, btype="low", fs=rate, output="sos")
    return LowPass(cutoff_hz=cutoff, sample_rate=rate, sos=np.asarray(sos))


def _part(
    robot: Robot,
    t: np.ndarray,
    q: np.ndarray,
    tau: np.ndarray,
    given: dict[str, np.ndarray],
    lowpass: LowPass | None,
) -> Part:
    if lowpass is None:
        return Part(t=t, q=q, v=given["v"], a=given["a"], tau=tau, keep=slice(None))
    step = 1.0 / lowpass.sample_rate
    count = math.floor((t[-1] - t[0]) / step + 1e-9) + 1 if t.size else 0
    if count > RESAMPLING_GROWTH * t.size + 1000:
        raise InvalidInput(
            f"the log's sampling is too irregular to resample: at its median interval "
            f"({step:.3g} s) its duration would take {count:.3g} samples, more than "
            f"{RESAMPLING_GROWTH} times the {t.size} it has; send v and a (then it is used as "
            "it is), or a log sampled more evenly"
        )
    grid = t[0] + step * np.arange(count) if t.size else t
    padlen = 3 * (2 * len(lowpass.sos) + 1)
    if grid.size <= max(padlen, 2 * lowpass.margin + 1):  # too short to filter: no samples
        zero = np.zeros((0, tau.shape[1]))
        return Part(
            t=grid[:0], q=np.zeros((0, q.shape[1])), v=zero, a=zero, tau=zero, keep=slice(None)
        )

    def resampled(x: np.ndarray) -> np.ndarray:
        out = np.empty((grid.size, x.shape[1]))
        for j in range(x.shape[1]):
            out[:, j] = np.interp(grid, t, x[:, j])
        return out

    with np.errstate(over="ignore", invalid="ignore"):
        x = lowpass(resampled(_coordinates(robot, q)))
        v = lowpass(resampled(given["v"])) if "v" in given else np.gradient(x, step, axis=0)
        a = lowpass(resampled(given["a"])) if "a" in given else np.gradient(v, step, axis=0)
        filtered_tau = lowpass(resampled(tau))
    _require_finite(
        (x, "positions q (filtered)"),
        (v, "velocities v (filtered)" if "v" in given else "velocities (differentiated from q)"),
        (a, "accelerations a (filtered)" if "a" in given else "accelerations (from q)"),
        (filtered_tau, "torques tau (filtered)"),
    )
    margin = lowpass.margin
    return Part(
        t=grid,
        q=joint_configurations(robot, x),
        v=v,
        a=a,
        tau=filtered_tau,
        keep=slice(margin, grid.size - margin),
    )


def _require_finite(*signals: tuple[np.ndarray, str]) -> None:
    """InvalidInput naming the first signal (array, its words) that is not finite: a log whose
    numbers are so large that filtering or differentiating them overflows float64."""
    for values, words in signals:
        if not np.isfinite(values).all():
            raise InvalidInput(
                f"identify: the log's {words} overflow float64: are its numbers extreme "
                "(SI units: rad or m, rad/s or m/s, rad/s² or m/s², N·m or N, s)?"
            )


def joint_ranges(robot: Robot, log: MotionLog) -> np.ndarray:
    """Each joint's range of motion (nv,), rad or m: max − min of its coordinate over the kept
    samples of both parts (filtered when the log is; a continuous joint's unwrapped angle).
    Zeros when no sample is kept."""
    kept = [_coordinates(robot, part.q[part.keep]) for part in (log.train, log.validation)]
    x = np.concatenate([k for k in kept if k.size] or [np.zeros((1, robot.nv))])
    return np.asarray(x.max(axis=0) - x.min(axis=0))


def _min_range(kind: str) -> float:
    return MIN_RANGE_PRISMATIC if kind == "prismatic" else MIN_RANGE_REVOLUTE


def barely_moving(robot: Robot, log: MotionLog) -> dict[str, float]:
    """The joints whose range of motion over the log is below their MIN_RANGE: {name: range
    (rad or m)}, in joint order."""
    ranges = joint_ranges(robot, log)
    out = {}
    for jid in range(1, robot.model.njoints):
        name = str(robot.model.names[jid])
        extent = float(ranges[robot.model.joints[jid].idx_v])
        if extent < _min_range(robot.joint_types[name]):
            out[name] = extent
    return out


def _min_speed(kind: str) -> float:
    return MIN_SPEED_PRISMATIC if kind == "prismatic" else MIN_SPEED_REVOLUTE


def joint_speeds(log: MotionLog) -> np.ndarray:
    """Each velocity coordinate's largest |v| over the kept samples of both parts (nv,), rad/s
    or m/s; zeros when no sample is kept."""
    kept = [np.abs(part.v[part.keep]) for part in (log.train, log.validation)]
    x = np.concatenate([k for k in kept if k.size] or [np.zeros((1, log.train.v.shape[1]))])
    return np.asarray(x.max(axis=0))


def unexcited_joints(robot: Robot, log: MotionLog) -> dict[str, str]:
    """The joints whose motion in the log does not determine their friction, in joint order:
    {name: why, for a user} — its range below MIN_RANGE, or its largest speed below
    MIN_SPEED (module docstring)."""
    ranges, speeds = joint_ranges(robot, log), joint_speeds(log)
    out = {}
    for jid in range(1, robot.model.njoints):
        name = str(robot.model.names[jid])
        kind = robot.joint_types[name]
        unit = "m" if kind == "prismatic" else "rad"
        iv = robot.model.joints[jid].idx_v
        extent, speed = float(ranges[iv]), float(speeds[iv])
        if extent < _min_range(kind):
            out[name] = (
                f"{name} moves over {extent if extent > 1e-12 else 0.0:.2g} {unit} in the log "
                f"(under {_min_range(kind):g} {unit}): its motion does not determine its "
                "friction, which is not reported or stored"
            )
        elif speed < _min_speed(kind):
            out[name] = (
                f"{name} moves at {speed:.2g} {unit}/s at most in the log (under "
                f"{_min_speed(kind):g} {unit}/s): its motion does not determine its friction, "
                "which is not reported or stored"
            )
    return out


def describe_ranges(robot: Robot, ranges: dict[str, float]) -> str:
    """ "shoulder_pan_joint 0.0013 rad, slider 0.0002 m" for `barely_moving`'s answer."""

    def unit(name: str) -> str:
        return "m" if robot.joint_types[name] == "prismatic" else "rad"

    return ", ".join(
        f"{name} {extent if extent > 1e-12 else 0.0:.2g} {unit(name)}"
        for name, extent in ranges.items()
    )  # (filtering leaves ~1e-17 of 0)


def check_motion(robot: Robot, log: MotionLog) -> None:
    """`InvalidInput` when every joint barely moves (see the module docstring): such a log
    has nothing to identify, and its fit is ill-posed (without noise, not even finite). A log
    in which only some joints barely move is fitted (the physically consistent fit keeps the
    model's values where it says nothing)."""
    if log.train.t[log.train.keep].size == 0:
        return  # too short: the sample count check says how many are needed
    still = barely_moving(robot, log)
    if len(still) < robot.nv:
        return
    raise InvalidInput(
        f"the log shows too little motion to identify robot '{robot.id}' (it does not excite "
        f"every base parameter): every joint barely moves (range over the log: "
        f"{describe_ranges(robot, still)}; a joint needs at least {MIN_RANGE_REVOLUTE:g} rad, "
        f"or {MIN_RANGE_PRISMATIC:g} m if prismatic, and much more to be identified well). "
        "A still robot's torques show only gravity at one configuration: excite every joint, "
        "moving each through a good part of its range at varied speeds and accelerations "
        "(e.g. a sum of sine waves)"
    )
