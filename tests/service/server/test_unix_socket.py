"""The Unix socket's file (service/server/unix_socket.py): its mode from the start, a stale
socket file replaced, a live one or another file refused."""

from __future__ import annotations

import os
import socket
import stat
from pathlib import Path

import pytest

from service.server.unix_socket import UnixSocketError, bind_unix_socket, remove_unix_socket


def test_the_socket_file_has_its_mode(tmp_path: Path):
    for mode in (0o600, 0o660):
        path = tmp_path / f"{mode:o}.sock"
        sock = bind_unix_socket(path, mode)
        try:
            assert stat.S_ISSOCK(os.lstat(path).st_mode)
            assert stat.S_IMODE(os.lstat(path).st_mode) == mode
        finally:
            sock.close()
            remove_unix_socket(path)
        assert not os.path.lexists(path)


def test_a_stale_socket_is_replaced_and_a_live_one_refused(tmp_path: Path):
    path = tmp_path / "robodyn.sock"
    stale = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    stale.bind(str(path))
    stale.close()  # the file stays, nobody listens: a server that died
    live = bind_unix_socket(path, 0o600)
    try:
        live.listen()
        with pytest.raises(UnixSocketError, match="already listening"):
            bind_unix_socket(path, 0o600)
    finally:
        live.close()
        remove_unix_socket(path)


def test_another_file_at_the_path_is_refused(tmp_path: Path):
    path = tmp_path / "robodyn.sock"
    path.write_text("not a socket")
    with pytest.raises(UnixSocketError, match="not a socket"):
        bind_unix_socket(path, 0o600)
    assert path.read_text() == "not a socket"
