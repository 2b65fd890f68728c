"""The Unix domain socket the server also listens on (`ROBODYN_UNIX_SOCKET`, `--unix-socket`).

`serve(config, socket_path, mode)` binds the TCP socket of `config` and the Unix socket, then
runs uvicorn's server on both (its supervisor with `config.workers` > 1, which hands both
sockets to every worker), and removes the socket file and the segment directory on the way
out. The socket file is created with `mode` (0600 by default) and never more open than that:
it is bound under a umask that leaves out every other bit. A socket file left by a server that
died is replaced; one a live server answers on is refused.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import signal
import socket
import stat
import sys
from pathlib import Path
from types import FrameType

from uvicorn import Config, Server
from uvicorn.config import STARTUP_FAILURE
from uvicorn.supervisors import Multiprocess

from service.segments import SegmentDirectory, segment_directory_of

log = logging.getLogger("robodyn")


class UnixSocketError(Exception):
    """The Unix socket cannot be bound (the message names the path and why)."""


def bind_unix_socket(path: Path, mode: int) -> socket.socket:
    """A listening-ready stream socket bound at `path`, its file mode `mode`."""
    _clear_stale_socket(path)
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    umask = os.umask(0o777 & ~mode)  # the file is created no more open than `mode`
    try:
        sock.bind(os.fspath(path))
    except OSError as exc:
        sock.close()
        raise UnixSocketError(f"cannot bind the Unix socket {path}: {exc.strerror}") from None
    finally:
        os.umask(umask)
    os.chmod(path, mode)
    sock.set_inheritable(True)  # the workers of uvicorn's supervisor serve it
    return sock


def _clear_stale_socket(path: Path) -> None:
    """Remove a socket file no server answers on; refuse a live one or any other file."""
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return
    if not stat.S_ISSOCK(info.st_mode):
        raise UnixSocketError(f"{path} exists and is not a socket")
    probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        probe.connect(os.fspath(path))
    except OSError as exc:
        if exc.errno not in (errno.ECONNREFUSED, errno.ENOENT):
            raise UnixSocketError(f"cannot check the Unix socket {path}: {exc.strerror}") from None
        os.unlink(path)  # left by a server that is gone
        return
    finally:
        probe.close()
    raise UnixSocketError(f"a server is already listening on {path}")


def remove_unix_socket(path: Path) -> None:
    with contextlib.suppress(FileNotFoundError):
        os.unlink(path)


def serve(config: Config, socket_path: Path, mode: int) -> None:
    """Run uvicorn on the TCP address of `config` and on the Unix socket `socket_path`; the
    socket file and its segment directory are removed when the server stops."""
    tcp = config.bind_socket()  # logs the TCP address (and exits when it is taken)
    segments = SegmentDirectory(segment_directory_of(socket_path))
    try:
        unix = bind_unix_socket(socket_path, mode)
        segments.create()
    except Exception as exc:  # (a SegmentDirectoryError or UnixSocketError: their messages)
        log.error("%s", exc)
        sys.exit(STARTUP_FAILURE)
    log.info("serving also on the Unix socket %s (mode %o)", socket_path, mode)
    # uvicorn's server ends by raising the signal that stopped it again, with the handler it
    # found: this one, which unwinds to the removal of the files below.
    handled = (signal.SIGTERM, signal.SIGINT)
    previous = {sig: signal.signal(sig, _stop) for sig in handled}
    server, stopped_by = None, None
    try:
        if config.workers > 1:
            Multiprocess(config, sockets=[tcp, unix]).run()
        else:
            config.load_app()
            server = Server(config)
            server.run(sockets=[tcp, unix])
    except _Stopped as stop:
        stopped_by = stop.signal
    except KeyboardInterrupt:
        pass
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for sock in (tcp, unix):
            sock.close()
        remove_unix_socket(socket_path)
        segments.delete()
    if stopped_by == signal.SIGTERM:  # ended by SIGTERM, as without the Unix socket
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        signal.raise_signal(signal.SIGTERM)
    if server is not None and not server.started:
        sys.exit(STARTUP_FAILURE)


class _Stopped(Exception):
    def __init__(self, sig: int) -> None:
        super().__init__(sig)
        self.signal = sig


def _stop(sig: int, frame: FrameType | None) -> None:
    raise _Stopped(sig)
