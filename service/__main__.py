"""`python -m service`: start the robodyn server (flags override ROBODYN_* settings)."""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

import uvicorn

from service.logs import configure_logging
from service.settings import Settings


def main(argv: list[str] | None = None) -> None:
    settings = Settings()
    parser = argparse.ArgumentParser(prog="python -m service", description=__doc__)
    parser.add_argument("--host", default=settings.host, help="interface (ROBODYN_HOST)")
    parser.add_argument("--port", type=int, default=settings.port, help="port (ROBODYN_PORT)")
    parser.add_argument(
        "--workers", type=int, default=settings.workers, help="server processes (ROBODYN_WORKERS)"
    )
    parser.add_argument(
        "--unix-socket",
        default=settings.unix_socket,
        help="also serve on this Unix domain socket (ROBODYN_UNIX_SOCKET)",
    )
    args = parser.parse_args(argv)
    # Passive OpenMP threads are woken for each chunk of a batch, and the scheduler came to put
    # the woken worker on its master's core: both shared one core and batches took twice as
    # long (2,000 Talos gravity states 12 ms instead of 6.7, measured). Bound (OMP_PROC_BIND),
    # a team keeps one core per thread. libgomp binds the thread that loads it too: the app
    # factory gives the event loop's thread every CPU back, and batches run in one dedicated thread
    # (service.dynamics.parallel). Set before pinocchio loads; an explicit setting wins.
    os.environ.setdefault("OMP_PROC_BIND", "true")
    # Workers build their settings from the environment: pass the flags on through it.
    os.environ["ROBODYN_HOST"], os.environ["ROBODYN_PORT"] = args.host, str(args.port)
    os.environ["ROBODYN_WORKERS"] = str(args.workers)
    if args.unix_socket:
        os.environ["ROBODYN_UNIX_SOCKET"] = str(Path(args.unix_socket).absolute())
    try:
        configure_logging(settings.log_level)  # JSON lines on stderr (service/logs.py)
    except ValueError as exc:
        parser.error(f"ROBODYN_LOG_LEVEL: {exc}")
    # log_config=None: uvicorn keeps our handlers; access_log=False: our middleware writes one
    # structured line per request instead (service/api/middleware/observability.py). The HTTP
    # protocol is uvicorn's httptools one with read timeouts, a connection cap and each answer
    # sent in one system call (service/server/protocol.py; its limits are read from the
    # ROBODYN_* settings).
    options: dict[str, Any] = dict(
        host=args.host,
        port=args.port,
        workers=args.workers,
        log_level=settings.log_level.lower(),
        log_config=None,
        access_log=False,
        timeout_graceful_shutdown=30,
        timeout_keep_alive=settings.keep_alive_timeout_s,
        http="service.server.protocol:HardenedHttpToolsProtocol",
    )
    if not args.unix_socket:
        uvicorn.run("service.main:app_from_environment", factory=True, **options)
        return
    # The TCP address and the Unix socket, served by the same processes
    # (service/server/unix_socket.py: its mode, and its removal on shutdown).
    from service.server.unix_socket import serve

    config = uvicorn.Config("service.main:app_from_environment", factory=True, **options)
    serve(config, Path(args.unix_socket).absolute(), settings.unix_socket_mode_bits())


if __name__ == "__main__":
    main()
