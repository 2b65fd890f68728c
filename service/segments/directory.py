"""The private directory of shared-memory segments beside the Unix socket, and its sweeper.

Names (nothing else in the directory is touched):

    c-<32 hex>          a client's body file or answer room, reused from request to request,
                        locked (flock, shared) by the client for as long as it keeps it
    r-<32 hex>          one request's body: a link to a client's body file, named in the request
    r-<32 hex>.answer   the answer to it: a link to the client's answer room (linked by the
                        client before the request, which names it), or to an answer file of the
                        service (or a file of its own), named in the answer
    s-<32 hex>          an answer file a server process reuses, locked by that process
                        (`service.segments.answer_pool`)
    .<name>.tmp         a c- or s- file being made, renamed once locked

A client holds its lock from before its body file has a name until it has read the answer and
removed the request's names; the kernel releases the lock when the process ends, however it
ends. So a request whose body nobody holds is one whose client is gone: the sweeper removes it
and its answer; so are a body or answer file nobody holds, an answer without its request, and a
temporary file unlocked for longer than `TEMPORARY_GRACE_S`. Each server process sweeps at
start-up and every `SWEEP_INTERVAL_S`; `python -m service` removes the directory on shutdown.
The directory is in memory (tmpfs) wherever the machine allows: see `SegmentDirectory.create`.
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import os
import re
import stat
import tempfile
import time
from pathlib import Path

from service.segments.answer_pool import AnswerPool
from service.segments.client_mappings import ClientMappings

log = logging.getLogger("robodyn")

NAME = re.compile(r"r-[0-9a-f]{32}")
ANSWER_SUFFIX = ".answer"
HELD_FILE = re.compile(r"[cs]-[0-9a-f]{32}")  # a client's body file, a server's answer file
TEMPORARY = re.compile(r"\.[cs]-[0-9a-f]{32}\.tmp")
TEMPORARY_GRACE_S = 10.0  # an unlocked temporary file younger than this may be being created
SWEEP_INTERVAL_S = 2.0
DIRECTORY_SUFFIX = ".segments"
MEMORY_FILESYSTEMS = frozenset(("tmpfs", "ramfs"))
SHM = Path("/dev/shm")


def segment_directory_of(socket_path: str | os.PathLike[str]) -> Path:
    """Where the clients of a Unix socket find its segments: `<socket path>.segments`, beside
    it (a directory, or a link to one in /dev/shm: see `SegmentDirectory.create`)."""
    return Path(os.fspath(socket_path) + DIRECTORY_SUFFIX)


def filesystem_type(path: str | os.PathLike[str]) -> str | None:
    """The type of the filesystem holding `path` (from /proc/self/mounts), or None."""
    try:
        lines = Path("/proc/self/mounts").read_text().splitlines()
    except OSError:
        return None
    real = os.path.realpath(path)
    best, kind = "", None
    for line in lines:
        fields = line.split()
        if len(fields) < 3:
            continue
        mount = fields[1].replace("\\040", " ")
        inside = real == mount or real.startswith(mount.rstrip("/") + "/")
        if inside and len(mount) >= len(best):
            best, kind = mount, fields[2]
    return kind


class SegmentDirectoryError(Exception):
    """The segment directory cannot be used (the message names the path and why)."""


def held(path: Path) -> bool:
    """Whether a process holds a lock on the file `path` (False when it does not exist)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC | os.O_NONBLOCK)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)  # (releases the lock just taken)
    return False


class SegmentDirectory:
    """`link`: where the clients look for the segments (`segment_directory_of` the socket);
    `path`: the directory itself, once `create` has found or made it."""

    def __init__(self, link: str | os.PathLike[str]) -> None:
        self.link = Path(link)
        self.path = self.link
        self.answers = AnswerPool(self.path)
        self.bodies = ClientMappings()  # the clients' body files, mapped (client_mappings.py)
        self.rooms = ClientMappings(writable=True)  # their answer rooms, mapped to write

    def create(self) -> None:
        """Make the directory (mode 0700), or take over an existing one of this user (left by
        an earlier run: swept here); anything else at `link` is refused. The segments must
        be in memory: the directory is made beside the socket when that is a memory
        filesystem (tmpfs: /run, /dev/shm, a Kubernetes emptyDir of medium Memory), else in
        /dev/shm with `link` a symbolic link to it (clients follow it and check that its
        target is a private directory of theirs), else beside the socket on disk."""
        try:
            info = os.lstat(self.link)
        except FileNotFoundError:
            self.path = self._make()
        else:
            if stat.S_ISLNK(info.st_mode) and info.st_uid == os.geteuid():
                self.path = Path(os.readlink(self.link))
                if not self.path.is_dir():  # (/dev/shm emptied since): made anew
                    os.unlink(self.link)
                    self.path = self._make()
            elif not stat.S_ISDIR(info.st_mode) or info.st_uid != os.geteuid():
                raise SegmentDirectoryError(
                    f"{self.link} exists and is not a directory of this user "
                    f"(uid {os.geteuid()}): remove it, or choose another ROBODYN_UNIX_SOCKET"
                )
        info = os.lstat(self.path)
        if not stat.S_ISDIR(info.st_mode) or info.st_uid != os.geteuid():
            raise SegmentDirectoryError(f"{self.path} is not a directory of this user")
        os.chmod(self.path, 0o700)  # private, whatever the umask or an earlier run left
        self.answers = AnswerPool(self.path)
        self.sweep()

    def _make(self) -> Path:
        in_memory = filesystem_type(self.link.parent) in MEMORY_FILESYSTEMS
        try:
            if in_memory or filesystem_type(SHM) not in MEMORY_FILESYSTEMS:
                if not in_memory:
                    log.warning(
                        "%s is not on a memory filesystem (nor is /dev/shm): shared-memory "
                        "segments go to disk pages there",
                        self.link.parent,
                    )
                os.mkdir(self.link, 0o700)
                return self.link
            target = Path(tempfile.mkdtemp(prefix=f"robodyn-{os.geteuid()}-", dir=SHM))
            os.symlink(target, self.link)
            return target
        except OSError as exc:
            raise SegmentDirectoryError(f"cannot create {self.link}: {exc.strerror}") from None

    def remove(self, name: str) -> int:
        """Remove the request segment `name` and its answer (each if present); how many."""
        removed = 0
        for each in (name + ANSWER_SUFFIX, name):
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.path / each)
                removed += 1
        return removed

    def sweep(self, everything: bool = False) -> int:
        """Remove the segments whose client is gone (see the module docstring), or with
        `everything` all of them (at shutdown); the number of files removed. Mappings of
        body files that have no name left are let go."""
        try:
            names = os.listdir(self.path)
        except FileNotFoundError:
            return 0
        removed = 0
        for name in names:
            try:
                removed += self._sweep_one(name, everything)
            except OSError:  # (a directory or a file of another user under a segment's name:
                continue  # not removable, not the service's; the others are swept)
        self.bodies.sweep()
        self.rooms.sweep()
        return removed

    def _sweep_one(self, name: str, everything: bool) -> int:
        """Remove the entry `name` if it is a segment whose client is gone (or `everything`);
        how many files that removed (a request segment goes with its answer)."""
        path = self.path / name
        if NAME.fullmatch(name):
            return self.remove(name) if everything or not held(path) else 0  # + answer
        if name.endswith(ANSWER_SUFFIX) and NAME.fullmatch(name[: -len(ANSWER_SUFFIX)]):
            gone = everything or not os.path.lexists(self.path / name[: -len(ANSWER_SUFFIX)])
        elif HELD_FILE.fullmatch(name):
            gone = everything or not held(path)
        elif TEMPORARY.fullmatch(name):
            gone = everything or (not held(path) and _age_s(path) > TEMPORARY_GRACE_S)
        else:
            return 0
        if not gone:
            return 0
        try:
            os.unlink(path)
        except FileNotFoundError:
            return 0
        return 1

    def delete(self) -> None:
        """Remove every segment and the directory itself (the server is shutting down)."""
        self.answers.close()
        self.bodies.close()
        self.rooms.close()
        self.sweep(everything=True)
        with contextlib.suppress(OSError):  # (files of other names: not the service's)
            os.rmdir(self.path)
        if self.path != self.link:
            with contextlib.suppress(OSError):
                os.unlink(self.link)


def _age_s(path: Path) -> float:
    try:
        return time.time() - os.lstat(path).st_mtime
    except FileNotFoundError:
        return 0.0
