"""`python -m service`: start the robodyn server (flags override ROBODYN_* settings)."""

from __future__ import annotations

import argparse
import logging
import os

import uvicorn

from service.settings import Settings


def main(argv: list[str] | None = None) -> None:
    settings = Settings()
    parser = argparse.ArgumentParser(prog="python -m service", description=__doc__)
    parser.add_argument("--host", default=settings.host, help="interface (ROBODYN_HOST)")
    parser.add_argument("--port", type=int, default=settings.port, help="port (ROBODYN_PORT)")
    parser.add_argument("--workers", type=int, default=settings.workers,
                        help="server processes (ROBODYN_WORKERS)")
    args = parser.parse_args(argv)
    # Workers build their settings from the environment: pass the flags on through it.
    os.environ["ROBODYN_HOST"], os.environ["ROBODYN_PORT"] = args.host, str(args.port)
    os.environ["ROBODYN_WORKERS"] = str(args.workers)
    level = settings.log_level.upper()
    logging.basicConfig(level=level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    uvicorn.run("service.main:app_from_environment", factory=True, host=args.host,
                port=args.port, workers=args.workers, log_level=settings.log_level.lower(),
                timeout_graceful_shutdown=30)


if __name__ == "__main__":
    main()
