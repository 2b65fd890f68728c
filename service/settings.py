"""Service settings: command-line flags and `ROBODYN_*` environment variables."""

from __future__ import annotations

from pathlib import Path

import platformdirs
from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict


def _default_data_dir() -> Path:
    return Path(platformdirs.user_data_dir("robodyn", appauthor=False))


class Settings(BaseSettings):
    """Every setting can be given as `ROBODYN_<NAME>` (e.g. `ROBODYN_DATA_DIR=/var/lib/robodyn`)."""

    model_config = SettingsConfigDict(env_prefix="ROBODYN_", extra="ignore")

    host: str = Field("127.0.0.1", description="Interface to listen on.")
    port: int = Field(8000, ge=0, le=65535, description="TCP port to listen on.")
    workers: int = Field(1, ge=1, le=64, description="Server processes (uvicorn workers).")
    data_dir: Path = Field(
        default_factory=_default_data_dir,
        description="Directory of the durable model store; replicas sharing it share uploads.",
    )
    api_keys: str = Field(
        "",
        description="Comma-separated API keys; when set, uploads and deletions need "
        "`Authorization: Bearer <key>`.",
    )
    catalog: str = Field(
        "",
        description="Comma-separated catalog robot names to load; empty loads the whole catalog.",
    )
    max_body_bytes: int = Field(
        64 * 1024 * 1024, ge=1024, description="Largest request body accepted, in bytes."
    )
    max_batch: int = Field(100_000, ge=1, description="Largest batch (states per request).")
    max_pending_batches: int = Field(
        16, ge=1, description="Large batches computed or queued at once per process; more are "
        "answered 503 overloaded with Retry-After.")
    max_simulation_steps: int = Field(
        100_000, ge=1, description="Largest number of steps of one simulate request, summed "
        "over the initial states of a batch (this bounds the answer's size).")
    max_simulation_work: int = Field(
        20_000_000, ge=1, description="Largest work of one simulate request: states × steps × "
        "nv × stages (1 for semi-implicit Euler, 4 for RK4); about 1–2 µs each.")
    build_timeout_s: float = Field(
        30.0, gt=0, description="Wall-clock limit for building an uploaded model, in seconds."
    )
    log_level: str = Field("info", description="Log level: debug, info, warning, error.")

    def api_key_list(self) -> list[str]:
        return [k.strip() for k in self.api_keys.split(",") if k.strip()]

    def catalog_names(self) -> list[str] | None:
        names = [n.strip() for n in self.catalog.split(",") if n.strip()]
        return names or None
