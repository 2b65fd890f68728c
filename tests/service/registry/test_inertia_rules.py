"""The rules every inertia check applies (uploads, the catalog's warnings, the model check),
and the power-of-ten slip that explains an error: the slips the public reports describe
(an `izz` that lost its decimal point, a product of inertia off by ten) are found, and an error
no single slip explains gets no suggestion."""

from __future__ import annotations

import numpy as np
import pytest

from service.registry.inertia_rules import inertia_error, power_of_ten_fix, tensor


def _attributes(**given: float) -> dict[str, float]:
    return {k: given.get(k, 0.0) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}


def test_each_error_is_named_and_tolerances_admit_rounding():
    assert inertia_error(1.0, np.diag([-0.1, 1.0, 1.0])).code == "negative_principal_moment"
    assert inertia_error(1.0, np.diag([0.1, 0.1, 1.0])).code == "triangle_inequality"
    assert inertia_error(0.0, np.diag([0.1, 0.1, 0.1])).code == "inertia_without_mass"
    assert inertia_error(1.0, np.zeros((3, 3))) is None  # a point mass
    assert inertia_error(0.0, np.zeros((3, 3))) is None
    # λ₁ + λ₂ = λ₃ (a thin plate) and a rounding-sized negative moment are bodies
    assert inertia_error(1.0, np.diag([1.0, 2.0, 3.0])) is None
    assert inertia_error(1.0, np.diag([-1e-20, 3e-6, 3e-6])) is None


def test_an_izz_that_lost_its_decimal_point_is_found():
    # 1.676 kg·m² on a 1.6 kg link whose other moments are 0.0118
    written = _attributes(ixx=0.0118, iyy=0.0118, izz=1.676)
    assert inertia_error(1.6, tensor(written)).code == "triangle_inequality"
    assert power_of_ten_fix(1.6, written) == ("izz", 0.01676)


def test_a_product_of_inertia_ten_times_too_large_is_found():
    written = _attributes(ixx=0.01, iyy=0.01, izz=0.01, ixy=0.03)
    assert inertia_error(1.0, tensor(written)).code == "negative_principal_moment"
    assert power_of_ten_fix(1.0, written) == ("ixy", 0.003)


@pytest.mark.parametrize(
    "written",
    [
        _attributes(ixx=-0.01, iyy=-0.01, izz=-0.01),  # every moment negative: no one slip
        _attributes(ixx=0.01, iyy=0.2, izz=0.5),  # ixx × 10 or izz ÷ 10 both fix it
    ],
)
def test_no_suggestion_where_no_single_slip_or_several_explain_the_error(written):
    assert inertia_error(1.0, tensor(written)) is not None
    assert power_of_ten_fix(1.0, written) is None
