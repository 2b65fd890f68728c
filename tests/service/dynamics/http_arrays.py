"""Dynamics requests with numpy arrays: POST a request whose body may hold numpy arrays and get
the answer as numpy arrays, and compare answers within a tolerance scaled by their magnitude."""

from __future__ import annotations

from typing import Any

import numpy as np


def post(api: Any, robot: str, quantity: str, status: int = 200, **body: Any) -> dict[str, Any]:
    """POST a dynamics request; arrays in the body may be numpy. The answer as numpy arrays
    (or the problem object for an expected error status)."""
    payload = {
        k: np.asarray(x).tolist() if isinstance(x, np.ndarray | list) else x
        for k, x in body.items()
    }
    r = api.post(f"/v1/robots/{robot}/{quantity}", json=payload)
    assert r.status_code == status, r.text
    if status != 200:
        return dict(r.json())
    return {k: np.asarray(x) for k, x in r.json().items()}


def close(actual: Any, expected: Any, rtol: float = 1e-9) -> None:
    """Equal within rtol relative to the largest magnitude of `expected` (at least 1)."""
    expected = np.asarray(expected)
    scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
    np.testing.assert_allclose(actual, expected, rtol=rtol, atol=rtol * scale)
