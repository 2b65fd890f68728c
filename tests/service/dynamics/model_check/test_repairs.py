"""Repairs: the nearest valid principal moments against a general-purpose constrained
least-squares solver (cvxpy with Clarabel), the repaired tensor keeping its principal axes, and the
massless link's only inertia."""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from service.dynamics.model_check.repairs import nearest_valid, nearest_valid_moments
from service.registry.inertia_rules import inertia_error
from service.registry.link_descriptions import LinkDescription


def _reference(moments: np.ndarray) -> np.ndarray:
    """The projection as a convex QP solved by cvxpy (Clarabel), at unit scale: the
    constraints are a cone, so the answer scales back."""
    scale = float(np.abs(moments).max())
    x = cp.Variable(3)
    constraints = [x >= 0] + [x[i] + x[j] >= x[k] for i, j, k in ((0, 1, 2), (0, 2, 1), (1, 2, 0))]
    cp.Problem(cp.Minimize(cp.sum_squares(x - moments / scale)), constraints).solve(
        solver=cp.CLARABEL
    )
    return np.asarray(x.value) * scale


@pytest.mark.parametrize("seed", range(12))
def test_the_nearest_valid_moments_are_the_constrained_least_squares_solution(seed):
    rng = np.random.default_rng(seed)
    moments = np.sort(rng.normal(0.0, 1.0, 3) * rng.choice([1e-3, 1.0, 10.0]))
    fixed = nearest_valid_moments(moments)
    np.testing.assert_allclose(
        fixed, _reference(moments), atol=1e-6 * max(1.0, np.abs(moments).max())
    )


def test_valid_moments_are_kept_and_the_slip_of_a_decimal_point_is_projected():
    np.testing.assert_array_equal(nearest_valid_moments(np.array([1.0, 2.0, 2.5])), [1.0, 2.0, 2.5])
    # λ₁ + λ₂ < λ₃: the closest point has λ₁ + λ₂ = λ₃, moved along (−1, −1, 1)/√3
    fixed = nearest_valid_moments(np.array([0.0118, 0.0118, 1.676]))
    t = (1.676 - 0.0236) / 3
    np.testing.assert_allclose(fixed, [0.0118 + t, 0.0118 + t, 1.676 - t], rtol=1e-12)


def test_the_repaired_tensor_keeps_the_centre_of_mass_and_principal_axes():
    axes = Rotation.from_euler("xyz", [0.3, -0.7, 1.2]).as_matrix()
    declared = axes @ np.diag([-0.002, 0.01, 0.02]) @ axes.T
    link = LinkDescription("l", 2.0, np.array([0.1, 0.2, 0.3]), declared, None, True)
    assert inertia_error(2.0, declared) is not None
    center, inertia = nearest_valid(link)
    np.testing.assert_array_equal(center, link.center_of_mass)
    assert inertia_error(2.0, inertia) is None
    in_axes = axes.T @ inertia @ axes
    np.testing.assert_allclose(in_axes, np.diag(np.diag(in_axes)), atol=1e-15)
    np.testing.assert_allclose(
        np.diag(in_axes), nearest_valid_moments(np.array([-0.002, 0.01, 0.02])), atol=1e-15
    )


def test_a_massless_link_is_repaired_to_no_inertia():
    link = LinkDescription("l", 0.0, np.array([0.1, 0, 0]), np.eye(3) * 0.01, None, True)
    assert inertia_error(0.0, link.inertia).code == "inertia_without_mass"
    _, inertia = nearest_valid(link)
    np.testing.assert_array_equal(inertia, np.zeros((3, 3)))
    assert inertia_error(0.0, inertia) is None
