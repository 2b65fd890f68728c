"""The naive baseline of bench/run.py: how a first FastAPI endpoint on Pinocchio is written.

pydantic `list[float]` body, a sync `def` endpoint (run in the thread pool), one shared
`pin.Data`, `.tolist()` answer serialized by FastAPI. Not part of the service.
Run: `uvicorn bench.naive_app:app --port 8102`.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from fastapi import FastAPI
from pydantic import BaseModel

from service.registry.catalog import erd_robots_dir

MODEL = pin.buildModelFromUrdf(str(erd_robots_dir() / "ur_description/urdf/ur5_robot.urdf"))
DATA = MODEL.createData()

app = FastAPI()


class Body(BaseModel):
    q: list[float]


@app.get("/health/live")
def live() -> dict[str, str]:
    return {"status": "ok"}


@app.post("/v1/robots/ur5/mass-matrix")
def mass_matrix(body: Body) -> dict[str, list[list[float]]]:
    M = pin.crba(MODEL, DATA, np.array(body.q))
    M = np.triu(M) + np.triu(M, 1).T
    return {"mass_matrix": M.tolist()}
