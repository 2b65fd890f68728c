"""Service settings: command-line flags and `ROBODYN_*` environment variables."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

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
    unix_socket: Path | None = Field(
        None,
        description="Also serve the whole API on this Unix domain socket (a path), for "
        "clients on the same host (`unix://` URLs of the Python client): their large binary "
        "batches travel through shared memory, in the private directory `<path>.segments` "
        "beside it. API keys and every limit apply as over TCP. The socket and the directory "
        "are removed on shutdown.",
    )
    unix_socket_mode: str = Field(
        "0600",
        pattern=r"^0?[0-7]{3}$",
        description="File mode of the Unix socket, in octal (0600: only the service's user "
        "may connect; 0660 adds its group). Shared-memory segments are 0600 whatever it is: "
        "a client on another user account is served through the socket itself.",
    )
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
    max_json_body_bytes: int = Field(
        16 * 1024 * 1024,
        ge=1024,
        description="Largest JSON request body other than an upload, "
        "in bytes: parsing JSON numbers holds the event loop (about 80 ms for 16 MiB), so "
        "larger batches are sent in the binary form (up to max_body_bytes).",
    )
    max_batch: int = Field(100_000, ge=1, description="Largest batch (states per request).")
    max_pending_batches: int = Field(
        16,
        ge=1,
        description="Large batches computed or queued at once per process; more are "
        "answered 503 overloaded with Retry-After.",
    )
    batch_helpers: int | None = Field(
        None,
        ge=-1,
        le=64,
        description="Helper processes per server process that compute a share of each large "
        "mass-matrix or Coriolis batch (Pinocchio computes these state by state on one core "
        "and holds the GIL), writing it into shared memory; -1: one per CPU the process may "
        "use (divided by the server processes, `workers`) but one; 0: off, every batch "
        "computed by the serving process alone. Unset (the default): -1 for requests over "
        "the Unix socket (`unix_socket`), off for requests over TCP (performance.md: on the "
        "quiet 2-core machine, through the socket, they took 2,000 Talos Coriolis matrices "
        "from 0.77 to 1.00–1.11 of a Python loop; with other work holding both cores they "
        "cost a little, and 0 turns them off; over TCP the transport bounds these batches).",
    )
    batch_helper_buffer_mb: int = Field(
        64,
        ge=1,
        le=4096,
        description="Shared memory of each batch helper for its share of a batch's inputs "
        "and answers, in MB, kept mapped between requests; a helper's share of a larger batch "
        "is cut to fit.",
    )
    max_simulation_steps: int = Field(
        100_000,
        ge=1,
        description="Largest number of steps of one simulate request, summed "
        "over the initial states of a batch (this bounds the answer's size).",
    )
    max_simulation_work: int = Field(
        20_000_000,
        ge=1,
        description="Largest work of one simulate request: states × steps × "
        "nv × stages (1 for semi-implicit Euler, 4 for RK4); about 1–2 µs each.",
    )
    max_work: int = Field(
        25_000_000,
        ge=1,
        description="Largest estimated work of one contact request "
        "(contact-dynamics, contact-inverse-dynamics, impulse-dynamics, simulate with "
        "contacts), in units of about 0.3–0.4 µs on one core: states (× steps × stages) × "
        "the work of one constrained evaluation, which grows with the contacts (m³ for m "
        "constraint rows) and, with damping, the worst case of its iterations. The default "
        "admits about 10 s of computing on one core.",
    )
    max_trajectory_work: int = Field(
        10_000_000,
        ge=1,
        description="Largest work of one trajectory-check: evaluated points × nv, where N "
        "samples give (N − 1) × samples_per_interval + 1 points when v and a come from the "
        "spline, else N. A unit costs about 0.9–1.2 µs of CPU (τ and the joint loads of the "
        "same RNEA pass, point by point) and at most about 56 bytes of memory (the samples "
        "are held whole, the points in chunks); the default admits about 13 s of CPU and "
        "at most 0.6 GB on a 126-joint tree, and a UR5's 1,000,000 evaluated points.",
    )
    max_retime_work: int = Field(
        500_000,
        ge=1,
        description="Largest work of one retime: path intervals × nv × limited quantities, "
        "where K waypoints give at most 800 + 16 (K − 1) intervals and the quantities are "
        "velocity and effort, and acceleration where acceleration limits are given. A unit "
        "costs about 5–25 µs on one core and 0.3–0.9 kB of memory (TOPP-RA holds the whole "
        "path's rows); the default admits about 12 s and 0.5 GB.",
    )
    request_deadline_s: float = Field(
        60.0,
        gt=0,
        description="Longest time a dynamics request computed off the event loop "
        "(a large batch, a simulation, a contact batch) may compute, in seconds from the "
        "start of its computation; past it the computation stops between chunks or steps and "
        "the answer is 504 deadline_exceeded (it also stops at once when the client "
        "disconnects).",
    )
    max_answer_bytes_in_flight: int = Field(
        1024 * 1024 * 1024,
        ge=1024,
        description="Largest total of the large HTTP answers (1 "
        "MiB or more, by their size estimate, then their encoded size) held by one process "
        "from admission until their clients have read them, in bytes; a request whose answer "
        "would pass it is answered 503 overloaded with Retry-After before computing (one "
        "answer alone always passes). It bounds the memory held for clients that do not read.",
    )
    data_pool_mb: int = Field(
        1024,
        ge=0,
        description="Memory kept for idle Pinocchio Data between computations, "
        "over all robots, in MB (a Data takes about 80·nv³ bytes; the whole catalog needs "
        "about 220 MB). Beyond it, the least recently used robots create theirs anew.",
    )
    heap_retain_mb: int = Field(
        64,
        ge=0,
        le=4096,
        description="Freed memory each process keeps in its C heap for the "
        "next large request, in MB (glibc only): large batches then skip re-faulting fresh "
        "pages (10,000 Talos states about 10% faster end to end). 0 keeps the C library's "
        "defaults (memory handed back sooner).",
    )
    build_timeout_s: float = Field(
        30.0, gt=0, description="Wall-clock limit for building an uploaded model, in seconds."
    )
    log_level: str = Field("info", description="Log level: debug, info, warning, error.")

    # -- hardening: API keys for reads and compute, upload limits (docs/security.md) --
    api_keys_scope: Literal["writes", "all"] = Field(
        "writes",
        description="With API keys set: `writes` guards uploads, reductions and "
        "deletions; `all` guards every /v1 route (reads and compute too). Health, metrics and "
        "docs stay open.",
    )
    max_upload_bytes: int = Field(
        64 * 1024 * 1024,
        ge=1024,
        description="Largest body of POST /v1/robots, in bytes, "
        "assets (base64) included: 64 MiB admits a robot arm with its meshes (the largest "
        "catalog URDF is 211 kB).",
    )
    max_links: int = Field(1000, ge=1, description="Most <link> elements in an uploaded model.")
    max_nv: int = Field(
        128,
        ge=1,
        description="Largest nv (velocity coordinates, root joint included) of an "
        "uploaded model; a Pinocchio Data takes about 80·nv³ bytes.",
    )
    max_depth: int = Field(128, ge=1, description="Deepest kinematic chain, in links.")
    max_xml_elements: int = Field(50_000, ge=10, description="Most XML elements in an upload.")
    max_xml_depth: int = Field(32, ge=4, description="Deepest XML element nesting.")
    max_name_length: int = Field(
        256,
        ge=16,
        le=256,
        description="Longest name in an uploaded description, in "
        "characters: <robot name>, link, joint, frame, MJCF body/joint/site names and <mujoco "
        "model> (names are echoed in answers). At most 256, the longest frame or joint name a "
        "request may give.",
    )
    build_memory_mb: int = Field(
        1024, ge=256, description="Address-space limit of the process that builds an upload, in MB."
    )
    build_cpu_s: int = Field(
        20, ge=1, description="CPU-time limit of the process that builds an upload, in seconds."
    )
    max_concurrent_builds: int = Field(
        0,
        ge=0,
        description="Uploads validated and built at once per server process (each in "
        "its own builder process); 0 means the CPU count, and more than the CPU count is "
        "capped to it. Further uploads wait for a free builder (see build_queue_timeout_s).",
    )
    build_queue_timeout_s: float = Field(
        30.0,
        gt=0,
        description="How long an upload may wait for a free builder, in seconds; "
        "beyond it (or with more than 4 uploads per builder waiting) the answer is 503 "
        "overloaded with Retry-After. The build timeout starts when the build does.",
    )
    equations_timeout_s: float = Field(
        60.0,
        gt=0,
        description="Time limit of deriving one robot's equations of motion in "
        "explicit form (GET /v1/robots/{id}/equations), in seconds of wall clock and of CPU "
        "time, in a child process; past it the answer is 422 unsupported_model, remembered "
        "for every robot with the same numbers (503 overloaded, not remembered, when the "
        "machine gave the derivation less than half of it on a CPU). A UR5 takes about 0.3 s.",
    )
    max_concurrent_derivations: int = Field(
        1,
        ge=1,
        description="Derivations of equations in explicit form run at once per server "
        "process (each in its own child process; slots of their own, never the upload "
        "builders'); more than the CPU count is capped to it. Further derivations wait for a "
        "free slot like uploads for a builder (build_queue_timeout_s, at most 4 per slot), "
        "then 503 overloaded with Retry-After.",
    )
    equations_memory_mb: int = Field(
        2048,
        ge=256,
        description="Address-space limit of the process deriving a robot's equations, in MB.",
    )
    equations_cache_mb: int = Field(
        256,
        ge=1,
        description="Memory kept for derived equations (JSON answers), per server "
        "process, in MB; the least recently used are dropped beyond it (stored models keep "
        "theirs on disk in the data directory).",
    )

    # -- identification (service/api/workers/identification.py; docs/identification.md) --
    identify_timeout_s: float = Field(
        120.0,
        gt=0,
        description="Wall-clock limit of one identification in its worker process, "
        "in seconds from the start of its fit (waiting for the worker is not counted); beyond "
        "it the worker process is killed and replaced (422, or 503 overloaded when the machine "
        "starved it). A client that disconnects stops its fit the same way at once.",
    )
    identify_memory_mb: int = Field(
        4096,
        ge=1024,
        description="Address-space limit of the identification worker process, in MB.",
    )
    max_identify_samples: int = Field(
        200_000, ge=100, description="Most samples in one identification log."
    )

    # -- connections and answers (service/server/protocol.py; see docs/security.md) --
    max_answer_bytes: int = Field(
        256 * 1024 * 1024,
        ge=1024,
        description="Largest answer of a dynamics request, in "
        "bytes, estimated before computing from the answer's shape (25 bytes a number in "
        "JSON, 8 in the binary form); larger ones are answered 413 payload_too_large naming "
        "the batch size that fits.",
    )
    header_timeout_s: float = Field(
        10.0,
        gt=0,
        description="Time a client has to send a request's line and headers, from "
        "its first byte (or from connecting), in seconds; then the connection is closed.",
    )
    body_timeout_s: float = Field(
        30.0,
        gt=0,
        description="Longest pause between two reads of a request body, in "
        "seconds; then the connection is closed.",
    )
    send_timeout_s: float = Field(
        60.0,
        gt=0,
        description="Longest time a client may leave its answer unread (the "
        "server's send buffer full), in seconds; then the connection is dropped.",
    )
    keep_alive_timeout_s: float = Field(
        5.0, gt=0, description="How long an idle kept-alive connection stays open, in seconds."
    )
    max_connections: int = Field(
        1024,
        ge=1,
        description="Open connections per process (at most the process's "
        "file-descriptor limit less 64); beyond, a new connection evicts the one idle "
        "longest, or is answered 503 overloaded when all are busy.",
    )

    def unix_socket_mode_bits(self) -> int:
        """`unix_socket_mode` as permission bits (e.g. 0o600)."""
        return int(self.unix_socket_mode, 8)

    def api_key_list(self) -> list[str]:
        return [k.strip() for k in self.api_keys.split(",") if k.strip()]

    def model_limits(self) -> dict[str, int]:
        """The caps of upload validation: keyword arguments of `urdf_check.Limits`."""
        return {
            "max_links": self.max_links,
            "max_nv": self.max_nv,
            "max_depth": self.max_depth,
            "max_elements": self.max_xml_elements,
            "max_xml_depth": self.max_xml_depth,
            "max_name_length": self.max_name_length,
        }

    def build_limits(self) -> dict[str, int]:
        """Keyword arguments of `build_isolated` besides the timeout."""
        return {"memory_mb": self.build_memory_mb, "cpu_s": self.build_cpu_s, "max_nv": self.max_nv}

    def catalog_names(self) -> list[str] | None:
        names = [n.strip() for n in self.catalog.split(",") if n.strip()]
        return names or None
