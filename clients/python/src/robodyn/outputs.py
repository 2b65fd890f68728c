"""Answers as the caller wants them: numpy (default) or torch tensors, and answers of chunks
joined back into one.

`ArrayType` names the array library of the answers. "torch" needs PyTorch, imported only
when asked for (the client does not depend on it): `torch.from_numpy` shares the answer's
memory, so the conversion copies nothing; the tensors are float64 on the CPU (`.to(device,
torch.float32)` for others).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any, Literal, TypeVar

import numpy as np

from robodyn.errors import InputError

ArrayType = Literal["numpy", "torch"]
ARRAY_TYPES: tuple[ArrayType, ...] = ("numpy", "torch")
T = TypeVar("T")


def check_array_type(array_type: Any) -> ArrayType:
    if array_type not in ARRAY_TYPES:
        raise InputError(
            f"array_type must be one of {', '.join(map(repr, ARRAY_TYPES))}, not {array_type!r}"
        )
    if array_type == "torch":
        _torch()  # fail now, not at the first answer
    result: ArrayType = array_type
    return result


def _torch() -> Any:
    try:
        import torch
    except ImportError:
        raise InputError('array_type="torch" needs PyTorch: pip install torch') from None
    return torch


def convert(result: T, array_type: ArrayType) -> T:
    """`result` (an array, a tuple or NamedTuple of arrays, a result dataclass, or anything
    else) with its numpy arrays as `array_type` arrays."""
    if array_type == "numpy":
        return result
    torch = _torch()

    def tensor(arr: np.ndarray) -> Any:
        return torch.from_numpy(arr if arr.flags.writeable else arr.copy())

    converted: T = _map(result, tensor)
    return converted


def _map(value: Any, fn: Callable[[np.ndarray], Any]) -> Any:
    if isinstance(value, np.ndarray):
        return fn(value)
    if isinstance(value, tuple):
        items = [_map(v, fn) for v in value]
        return _tuple(value, items)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.replace(
            value,
            **{
                f.name: _map(getattr(value, f.name), fn)
                for f in dataclasses.fields(value)
                if f.init
            },
        )
    return value


def join(parts: Sequence[T], axis: int = 0) -> T:
    """One answer from the answers of consecutive chunks of a batch: arrays concatenated along
    `axis` (the batch axis), tuples and result dataclasses field by field, None stays None."""
    joined: T = _join(list(parts), axis)
    return joined


def _join(parts: list[Any], axis: int) -> Any:
    first = parts[0]
    if isinstance(first, np.ndarray):
        return np.concatenate(parts, axis=axis)
    if isinstance(first, tuple):
        items = [_join([p[i] for p in parts], axis) for i in range(len(first))]
        return _tuple(first, items)
    if dataclasses.is_dataclass(first) and not isinstance(first, type):
        return dataclasses.replace(
            first,
            **{
                f.name: _join([getattr(p, f.name) for p in parts], axis)
                for f in dataclasses.fields(first)
                if f.init
            },
        )
    return first


def _tuple(like: tuple[Any, ...], items: list[Any]) -> tuple[Any, ...]:
    """`items` as a tuple of the same kind as `like` (a NamedTuple keeps its class)."""
    make: Any = getattr(type(like), "_make", None)
    if make is None:
        return tuple(items)
    named: tuple[Any, ...] = make(items)
    return named
