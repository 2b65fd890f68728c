"""Answers of the health routes (outside /v1)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field


class Liveness(BaseModel):
    status: Literal["ok"] = Field(description='Always "ok": the process answers.')


class Readiness(BaseModel):
    status: Literal["ready"] = Field(
        description='"ready": the catalog is loaded and the '
        "service computes (before that the answer is a 503 "
        "problem with code not_ready)."
    )
    robots: int = Field(description="How many catalog robots are served.")
    unavailable: list[str] = Field(
        description="Catalog robots this server could not load (GET /v1/robots says why)."
    )
