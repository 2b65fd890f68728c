"""Checked inputs of the trajectory computations: each error names the field at fault and says
what was expected, never echoing a value (which could be huge or not finite)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from service.errors import DimensionMismatch, InvalidInput


def _array(name: str, value: Any, ndim: int) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (ValueError, TypeError):
        raise InvalidInput(
            f"{name} must be an array of numbers" + (" (one row per sample)" if ndim == 2 else "")
        ) from None
    if arr.ndim != ndim:
        shape = "1-D" if ndim == 1 else "2-D (one row per sample)"
        raise InvalidInput(f"{name} must be {shape}, not {arr.ndim}-D")
    if not np.isfinite(arr).all():
        raise InvalidInput(f"{name} contains a non-finite number (NaN or infinity)")
    return arr


def sample_times(name: str, value: Any) -> np.ndarray:
    """Sample times (s): 1-D, finite, at least 2, strictly increasing."""
    t = _array(name, value, 1)
    if t.shape[0] < 2:
        raise InvalidInput(f"{name} has {t.shape[0]} sample(s); a trajectory needs at least 2")
    steps = np.diff(t)
    bad = np.flatnonzero(~(steps > 0))
    if bad.size:
        i = int(bad[0])
        raise InvalidInput(
            f"{name} must be strictly increasing: {name}[{i + 1}] is not after {name}[{i}]"
        )
    return t


def samples(
    name: str, value: Any, count: int, width: int, width_name: str, count_name: str
) -> np.ndarray:
    """A 2-D array of `count` rows (one per entry of `count_name`) of `width` numbers each
    (the robot's `width_name`: nq or nv)."""
    arr = _array(name, value, 2)
    if arr.shape[0] != count:
        raise DimensionMismatch(f"{name} has {arr.shape[0]} rows; {count_name} has {count}")
    if arr.shape[1] != width:
        raise DimensionMismatch(
            f"each row of {name} has {arr.shape[1]} entries; the robot has {width_name} = {width}"
        )
    return arr


def positive(name: str, value: Any) -> float:
    """A finite number > 0 (a scale, a limit, a time step)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InvalidInput(f"{name} must be a number")
    x = float(value)
    if not math.isfinite(x) or x <= 0.0:
        raise InvalidInput(f"{name} must be a finite number greater than 0")
    return x


def acceleration_limits(name: str, value: Any, width: int) -> np.ndarray | None:
    """Joint acceleration limits: None, or `width` (nv) entries each a finite number > 0 or
    None (no limit on that joint); an array [nv] with inf for no limit, or None where no
    entry limits anything."""
    if value is None:
        return None
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise InvalidInput(f"{name} must be an array of nv numbers or nulls")
    entries = [np.inf if x is None else x for x in value]
    try:
        arr = np.asarray(entries, dtype=np.float64)
    except (ValueError, TypeError):
        raise InvalidInput(f"{name} must be an array of nv numbers or nulls") from None
    if arr.ndim != 1:
        raise InvalidInput(f"{name} must be 1-D, not {arr.ndim}-D")
    if arr.shape[0] != width:
        raise DimensionMismatch(f"{name} has {arr.shape[0]} entries; the robot has nv = {width}")
    given = np.array([x is not None for x in value], dtype=bool)
    bad = np.flatnonzero(given & ~((arr > 0) & np.isfinite(arr)))
    if bad.size:
        raise InvalidInput(
            f"{name} must be finite numbers greater than 0 (or null: no limit); entry "
            f"{int(bad[0])} is not"
        )
    return arr if given.any() else None
