"""Answer schema of the centroidal momentum (`service.dynamics.centroidal`), with sizes and
units; its request is the common `QVRequest`."""

from __future__ import annotations

from pydantic import BaseModel, Field

from service.api.schemas.common import Matrix, Vector


class CentroidalAnswer(BaseModel):
    momentum: Vector = Field(
        description="Centroidal momentum h_G = A_G(q) v, 6 entries: linear "
        "momentum m ċ (kg·m/s) then angular momentum about the centre of "
        "mass (kg·m²/s), world-aligned axes; (N, 6) for a batch."
    )
    momentum_matrix: Matrix = Field(
        description="Centroidal momentum matrix A_G(q), 6×nv (h_G = A_G v); (N, 6, nv) for a batch."
    )
    center_of_mass: Vector = Field(description="Centre of mass c(q), 3 entries, m, world frame.")
