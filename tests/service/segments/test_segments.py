"""The segment directory and one request's segments (service/segments), against the client's
side of the protocol (robodyn/shared_memory.py), without a server: who removes what, when."""

from __future__ import annotations

import gc
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from robodyn import answer_rooms, shared_memory

from service.api.encoding import binary
from service.api.encoding.shared_bodies import AnswerWriter
from service.segments import RequestSegment, SegmentDirectory, SegmentError
from service.segments.client_mappings import MAX_KEPT
from service.segments.directory import TEMPORARY_GRACE_S, SegmentDirectoryError
from service.segments.segment import HEADER_ROOM, SegmentTooLarge

ROOT = Path(__file__).resolve().parents[3]
HOLDER = """
import sys, time
from robodyn import answer_rooms, shared_memory
segment = shared_memory.SharedMemory(sys.argv[1]).segment([b"x" * 1000])
print(segment.name, flush=True)
time.sleep(600)
"""


@pytest.fixture
def directory(tmp_path: Path) -> SegmentDirectory:
    segments = SegmentDirectory(tmp_path / "robodyn.sock.segments")
    segments.create()
    yield segments
    segments.delete()


def test_the_directory_is_private_in_memory_and_removed(tmp_path: Path):
    segments = SegmentDirectory(tmp_path / "s.sock.segments")
    segments.create()
    info = os.lstat(segments.path)
    assert stat.S_ISDIR(info.st_mode) and stat.S_IMODE(info.st_mode) == 0o700
    if segments.path != segments.link:  # tmp_path on disk: in /dev/shm, the link beside
        assert os.readlink(segments.link) == str(segments.path)
        assert str(segments.path).startswith("/dev/shm/")
    again = SegmentDirectory(segments.link)  # a second process (worker) finds the same one
    again.create()
    assert again.path == segments.path
    segments.delete()
    assert not os.path.lexists(segments.link) and not os.path.lexists(segments.path)


def test_a_path_taken_by_something_else_is_refused(tmp_path: Path):
    (tmp_path / "x.segments").write_text("not a directory")
    with pytest.raises(SegmentDirectoryError, match="not a directory of this user"):
        SegmentDirectory(tmp_path / "x.segments").create()


@pytest.fixture
def no_rooms(monkeypatch: pytest.MonkeyPatch) -> None:
    """Clients that offer no answer room: answers go into the service's answer files."""
    monkeypatch.setattr(answer_rooms, "MAX_ROOMS", 0)


def _socket_of(directory: SegmentDirectory) -> str:
    return str(directory.link)[: -len(".segments")]


def test_a_body_round_trip_and_who_removes_it(directory: SegmentDirectory):
    """Each answer goes into an answer room of the client's and is lent to the caller (no
    copy: the caller's array is the room's memory); a room serves no other request while the
    answer is alive, and is reused once it is gone. The client removes every name it made."""
    q = np.random.default_rng(0).normal(size=(300, 7))
    client = shared_memory.SharedMemory(_socket_of(directory))
    parts = binary.encode_parts({"q": q})
    answers = []
    for round_ in range(3):  # the body file is reused; each kept answer holds its own room
        segment = client.segment(parts)
        assert segment is not None and segment.length == sum(len(p) for p in parts)
        assert segment.room == segment.name + ".answer"
        served = RequestSegment(directory, segment.name, segment.length, 1 << 20, segment.room)
        fields, arrays = binary.decode(served.body)
        assert fields == {} and np.array_equal(arrays["q"], q)
        del arrays
        header = served.write_answer(binary.encode_parts({"tau": q * round_}))
        served.end()  # the client holds its lock: the names stay for it
        names = sorted(os.listdir(directory.path))
        # the body file, the rooms of the answers kept so far and this request's, the
        # request's names; no file of the service's
        assert [n[:2] for n in names] == ["c-"] * (round_ + 2) + ["r-", "r-"]
        segment.settled = True  # (the server's answer read whole)
        answers.append(segment.answer(header, 200))
        segment.release()
        assert [n[:2] for n in sorted(os.listdir(directory.path))] == ["c-"] * (round_ + 2)
    rooms = sorted(n for n in os.listdir(directory.path) if n.startswith("c-"))
    for round_, content in enumerate(answers):  # each answer the caller's own
        tau = binary.decode(content)[1]["tau"]
        assert np.array_equal(tau, q * round_)
        tau[0, 0] = 1234.5  # the room's memory itself: seen in its file
        assert any(
            np.array_equal(
                np.frombuffer((directory.path / room).read_bytes()[: len(content)], np.uint8),
                np.frombuffer(content, np.uint8),
            )
            for room in rooms
        )
    del answers, content, tau
    gc.collect()  # the answers are gone: their rooms are free, and reused
    segment = client.segment(parts)
    assert segment is not None and segment.room is not None
    segment.settled = True
    segment.release()
    assert sorted(n for n in os.listdir(directory.path) if n.startswith("c-")) == rooms
    client.close()
    assert os.listdir(directory.path) == []


def test_answers_are_copied_while_every_room_is_lent(directory: SegmentDirectory):
    """With the answers of `MAX_ROOMS` rooms alive, a request offers none: its answer is in
    a file of the service's and copied out; once one answer is gone, its room serves again."""
    q = np.random.default_rng(6).normal(size=(200, 7))
    client = shared_memory.SharedMemory(_socket_of(directory))
    kept = []
    for round_ in range(answer_rooms.MAX_ROOMS + 1):
        segment = client.segment(binary.encode_parts({"q": q}))
        assert segment is not None
        assert (segment.room is None) == (round_ == answer_rooms.MAX_ROOMS)
        served = RequestSegment(directory, segment.name, segment.length, 1 << 20, segment.room)
        header = served.write_answer(binary.encode_parts({"tau": q + round_}))
        served.end()
        segment.settled = True
        kept.append(binary.decode(segment.answer(header, 200))[1]["tau"])
        segment.release()
    assert len([n for n in os.listdir(directory.path) if n.startswith("s-")]) == 1
    for round_, tau in enumerate(kept):
        assert np.array_equal(tau, q + round_)
    del kept[0], tau
    gc.collect()
    segment = client.segment(binary.encode_parts({"q": q}))
    assert segment is not None and segment.room is not None
    segment.release()
    client.close()


def test_a_room_whose_request_did_not_end_is_not_reused(directory: SegmentDirectory):
    """A request that ended without the server's answer read whole (a timeout, a dropped
    connection: the server may still write into the room) closes its room for good."""
    client = shared_memory.SharedMemory(_socket_of(directory))
    segment = client.segment([b"x" * 100])
    assert segment is not None and segment.room is not None
    files = {n for n in os.listdir(directory.path) if n.startswith("c-")}
    segment.release()  # (not settled)
    left = {n for n in os.listdir(directory.path) if n.startswith("c-")}
    assert len(files) == 2 and len(left) == 1  # the body file kept, the room gone
    client.close()


def test_a_room_is_a_file_its_client_holds(directory: SegmentDirectory):
    """The service writes only into a room that is a private regular file locked by a
    client: not a file nobody holds, nor an answer file of its own, nor a link elsewhere."""
    client = shared_memory.SharedMemory(_socket_of(directory))
    segment = client.segment([b"x" * 100])
    assert segment is not None and segment.room is not None
    room = directory.path / segment.room
    os.unlink(room)
    room.write_bytes(b"y" * 100)  # nobody holds it
    with pytest.raises(SegmentError, match="locked by its client"):
        RequestSegment(directory, segment.name, 100, 1 << 20, segment.room)
    os.unlink(room)
    own = directory.answers.take(64)
    assert own is not None
    os.link(directory.path / own.name, room)  # an answer file of the service's
    with pytest.raises(SegmentError, match="locked by its client"):
        RequestSegment(directory, segment.name, 100, 1 << 20, segment.room)
    directory.answers.give(own)
    os.unlink(room)
    os.symlink(directory.path / segment.name, room)
    with pytest.raises(SegmentError, match="cannot be opened"):
        RequestSegment(directory, segment.name, 100, 1 << 20, segment.room)
    with pytest.raises(SegmentError, match="must name r-"):
        RequestSegment(directory, segment.name, 100, 1 << 20, "r-" + "0" * 32 + ".answer")
    os.unlink(room)
    segment.release()
    client.close()


def test_bodies_of_every_size_in_one_reused_file(directory: SegmentDirectory):
    """The body file keeps its mapping from request to request, growing for a larger body: a
    smaller body after a larger one, and a larger after a smaller, arrive as sent (answers
    alike, in the client's reused answer room)."""
    client = shared_memory.SharedMemory(_socket_of(directory))
    rng = np.random.default_rng(1)
    for rows in (10, 2000, 3, 5000, 1):
        q = rng.normal(size=(rows, 7))
        parts = binary.encode_parts({"q": q})
        segment = client.segment(parts)
        assert segment is not None and segment.length == sum(len(p) for p in parts)
        served = RequestSegment(directory, segment.name, segment.length, 1 << 24, segment.room)
        assert np.array_equal(binary.decode(served.body)[1]["q"], q)
        header = served.write_answer(binary.encode_parts({"tau": -q}))
        served.end()
        segment.settled = True
        assert np.array_equal(binary.decode(segment.answer(header, 200))[1]["tau"], -q)
        segment.release()
    assert len([n for n in os.listdir(directory.path) if n.startswith("c-")]) == 2  # + room
    client.close()


def test_the_service_keeps_body_files_mapped_while_their_clients_keep_them(
    directory: SegmentDirectory,
):
    """A client's body file is mapped once for all its requests; the mapping is let go when
    the file has no name left (the sweep after the client closed), and arrays still read
    from it stay valid; more clients than `MAX_KEPT` keep no more mappings than that."""
    q = np.random.default_rng(2).normal(size=(4000, 7))
    parts = binary.encode_parts({"q": q})
    client = shared_memory.SharedMemory(_socket_of(directory))
    mappings = set()
    for _ in range(3):
        segment = client.segment(parts)
        assert segment is not None
        served = RequestSegment(directory, segment.name, segment.length, 1 << 24, segment.room)
        assert isinstance(served.body, memoryview) and len(served.body) == segment.length
        mappings.add(id(served.body.obj))
        kept = binary.decode(served.body)[1]["q"]  # (a request's arrays, read later)
        served.end()
        segment.release()
    assert len(mappings) == 1 and len(directory.bodies) == 1
    directory.sweep()
    assert len(directory.bodies) == 1  # its client still keeps the file
    client.close()
    directory.sweep()
    assert len(directory.bodies) == 0
    assert np.array_equal(kept, q)  # the mapping ends with the last array reading it
    clients = [shared_memory.SharedMemory(_socket_of(directory)) for _ in range(MAX_KEPT + 3)]
    for each in clients:
        segment = each.segment(parts)
        assert segment is not None
        served = RequestSegment(directory, segment.name, segment.length, 1 << 24, segment.room)
        assert np.array_equal(binary.decode(served.body)[1]["q"], q)
        served.end()
        segment.release()
    assert len(directory.bodies) == MAX_KEPT
    for each in clients:
        each.close()


def test_an_answer_computed_in_its_answer_file_is_written_with_its_header_only(
    directory: SegmentDirectory, no_rooms: None
):
    """`answer_arrays` gives arrays in an answer file; an answer made of them is not copied
    (its header goes before them, padded to HEADER_ROOM) and reads as sent; other arrays, or
    none written, give the file back for the next request."""
    client = shared_memory.SharedMemory(_socket_of(directory))
    q = np.random.default_rng(3).normal(size=(500, 7))
    for round_ in range(3):
        segment = client.segment(binary.encode_parts({"q": q}))
        served = RequestSegment(directory, segment.name, segment.length, 1 << 24, segment.room)
        arrays = served.answer_arrays({"tau": (500, 7), "norm": (500,)})
        assert served.answer_arrays({"tau": (1,)}) is None  # (once per request)
        if round_ == 2:  # an answer never written: the file goes back at the end
            served.end()
            segment.release()
            break
        arrays["tau"][:] = q * 2
        arrays["norm"][:] = np.linalg.norm(q, axis=1)
        answer = dict(arrays) if round_ == 0 else {"tau": q * 2, "norm": arrays["norm"].copy()}
        # written as its header only (on the event loop) exactly when computed in place
        assert AnswerWriter(served).header_only(answer) == (round_ == 0)
        parts = binary.encode_parts(answer)
        header = served.write_answer(parts)
        if round_ == 0:  # in place: the header padded, the arrays are the file's bytes
            size = HEADER_ROOM + q.nbytes + 500 * 8
            assert header.endswith(f" {size}")
            arrays["tau"][0, 0] = 123.0  # (written after: seen in the file, no copy made)
        served.end()
        content = binary.decode(segment.answer(header, 200))[1]
        expected_tau = q * 2
        if round_ == 0:
            expected_tau[0, 0] = 123.0
        assert np.array_equal(content["tau"], expected_tau)
        assert np.array_equal(content["norm"], np.linalg.norm(q, axis=1))
        segment.release()
    files = [n for n in os.listdir(directory.path) if n.startswith("s-")]
    # the reserved file, given back each time, and the one the answer not in place was copied
    # into (the reserved one stays taken while it is copied from)
    assert len(files) == 2
    client.close()


@pytest.mark.parametrize("case", ["one array elsewhere", "header too long", "order"])
def test_an_answer_partly_in_its_answer_file_is_copied_whole(directory: SegmentDirectory, case):
    """An answer whose parts view the reserved arrays but cannot be written in place (another
    array beside them, a header over HEADER_ROOM, another order) is copied into another
    file, never over the arrays it is copied from."""
    client = shared_memory.SharedMemory(_socket_of(directory))
    q = np.random.default_rng(4).normal(size=(400, 7))
    segment = client.segment(binary.encode_parts({"q": q}))
    served = RequestSegment(directory, segment.name, segment.length, 1 << 24, segment.room)
    arrays = served.answer_arrays({"tau": (400, 7), "norm": (400,)})
    arrays["tau"][:] = q * 3
    arrays["norm"][:] = np.arange(400.0)
    answer = {
        "one array elsewhere": {"tau": arrays["tau"], "norm": np.arange(400.0)},
        "header too long": {"note": "x" * (2 * HEADER_ROOM), **arrays},
        "order": {"norm": arrays["norm"], "tau": arrays["tau"]},
    }[case]
    assert not AnswerWriter(served).header_only(answer)
    header = served.write_answer(binary.encode_parts(answer))
    served.end()
    fields, content = binary.decode(segment.answer(header, 200))
    assert np.array_equal(content["tau"], q * 3)
    assert np.array_equal(content["norm"], np.arange(400.0))
    assert fields == ({"note": "x" * (2 * HEADER_ROOM)} if case == "header too long" else {})
    segment.release()
    client.close()


def test_no_room_for_the_answer_arrays_leaves_them_to_new_memory(
    directory: SegmentDirectory, monkeypatch, no_rooms: None
):
    """When the answer file cannot grow (ENOSPC), `answer_arrays` gives none (the answer is
    made in new memory) and the file is free for the next request."""
    from service.segments import answer_pool

    client = shared_memory.SharedMemory(_socket_of(directory))
    segment = client.segment(binary.encode_parts({"q": np.zeros((300, 7))}))
    served = RequestSegment(directory, segment.name, segment.length, 1 << 24, segment.room)
    real = answer_pool.os.posix_fallocate

    def full(fd: int, offset: int, length: int) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(answer_pool.os, "posix_fallocate", full)
    assert served.answer_arrays({"tau": (300, 7)}) is None
    monkeypatch.setattr(answer_pool.os, "posix_fallocate", real)
    assert served.answer_arrays({"tau": (300, 7)}) is not None
    assert len([n for n in os.listdir(directory.path) if n.startswith("s-")]) == 1  # (given back)
    served.end()
    segment.release()
    client.close()


def test_a_full_file_system_sends_the_body_through_the_socket(
    directory: SegmentDirectory, monkeypatch
):
    """When the body file cannot grow (ENOSPC), the client gets no segment (the body goes
    through the socket itself) and keeps no file: an error, never a SIGBUS on a mapping."""

    def full(fd: int, offset: int, length: int) -> None:
        raise OSError(28, "No space left on device")

    client = shared_memory.SharedMemory(_socket_of(directory))
    monkeypatch.setattr(shared_memory.os, "posix_fallocate", full)
    assert client.segment([b"x" * 100_000]) is None
    assert [n for n in os.listdir(directory.path) if n.startswith(("c-", "r-"))] == []
    client.close()


def test_the_service_removes_the_names_of_a_client_gone(
    directory: SegmentDirectory, no_rooms: None
):
    client = shared_memory.SharedMemory(_socket_of(directory))
    segment = client.segment([b"x" * 100])
    assert segment is not None
    served = RequestSegment(directory, segment.name, 100, 1 << 20)
    client.close()  # (as the client's process ending: its lock goes with its descriptors,
    segment._file.mapping.close()  # the mapping's duplicate of it too)
    os.close(segment._file.fd)
    served.write_answer([b"y" * 64])
    served.end()  # the request's names: removed at once
    assert sorted(n[:2] for n in os.listdir(directory.path)) == ["c-", "s-"]
    assert directory.sweep() == 1  # the dead client's body file: by the sweeper
    assert [n[:2] for n in os.listdir(directory.path)] == ["s-"]


def test_an_entry_the_sweeper_cannot_remove_leaves_it_sweeping_the_others(
    directory: SegmentDirectory,
):
    """A directory under a request's name (another process of the service's user made it) is
    not removable: it stays, and an unheld request segment beside it is still removed."""
    blocker = directory.path / ("r-" + "e" * 32)
    blocker.mkdir()
    dead = directory.path / ("r-" + "f" * 32)
    dead.write_bytes(b"z")
    assert directory.sweep() == 1
    assert os.listdir(directory.path) == [blocker.name]
    blocker.rmdir()  # (else the directory, in /dev/shm, outlives the test)


def test_the_sweeper_keeps_live_clients_and_removes_dead_ones(directory: SegmentDirectory):
    env = {**os.environ, "PYTHONPATH": str(ROOT / "clients/python/src")}
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLDER, _socket_of(directory)],
        env=env,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout is not None
        name = holder.stdout.readline().strip()
        files = [n for n in os.listdir(directory.path) if n.startswith("c-")]  # body, room
        assert len(files) == 2
        orphan = directory.path / ("r-" + "a" * 32 + ".answer")  # its request is gone
        orphan.write_bytes(b"z")
        stale = directory.path / (".c-" + "b" * 32 + ".tmp")  # a creator died long ago
        stale.write_bytes(b"z")
        old = time.time() - 2 * TEMPORARY_GRACE_S
        os.utime(stale, (old, old))
        fresh = directory.path / (".c-" + "c" * 32 + ".tmp")  # maybe being created now
        fresh.write_bytes(b"z")
        dead_server = directory.path / ("s-" + "d" * 32)  # no process holds it
        dead_server.write_bytes(b"z")
        other = directory.path / "not-ours"
        other.write_bytes(b"z")
        assert directory.sweep() == 3
        kept = [name, name + ".answer", *files, fresh.name, other.name]  # (+ its room)
        assert sorted(os.listdir(directory.path)) == sorted(kept)
        holder.send_signal(signal.SIGKILL)
        holder.wait(10)
        assert directory.sweep() == 4  # the dead client's request, answer, body file, room
        assert sorted(os.listdir(directory.path)) == sorted([fresh.name, other.name])
    finally:
        if holder.poll() is None:
            holder.send_signal(signal.SIGKILL)
            holder.wait(10)
        if holder.stdout is not None:
            holder.stdout.close()
        other.unlink()


def test_what_the_service_refuses_to_map(directory: SegmentDirectory, tmp_path: Path):
    for name in ("../x", "r-" + "0" * 31, "r-" + "G" * 32, "c-" + "0" * 32):
        with pytest.raises(SegmentError, match="not a segment name"):
            RequestSegment(directory, name, 16, 1024)
    with pytest.raises(SegmentError, match="does not exist"):
        RequestSegment(directory, "r-" + "0" * 32, 16, 1024)
    readable = directory.path / ("r-" + "1" * 32)
    readable.write_bytes(b"x" * 16)
    os.chmod(readable, 0o644)
    with pytest.raises(SegmentError, match="readable by no one else"):
        RequestSegment(directory, readable.name, 16, 1024)
    os.chmod(readable, 0o600)
    with pytest.raises(SegmentError, match="holds 16 bytes, fewer than the 17"):
        RequestSegment(directory, readable.name, 17, 1024)
    target = tmp_path / "elsewhere"
    target.write_bytes(b"x" * 16)
    os.chmod(target, 0o600)
    os.symlink(target, directory.path / ("r-" + "2" * 32))
    with pytest.raises(SegmentError, match="cannot be opened"):
        RequestSegment(directory, "r-" + "2" * 32, 16, 1024)
    with pytest.raises(SegmentTooLarge):
        RequestSegment(directory, readable.name, 2048, 1024)
    for each in os.listdir(directory.path):
        os.unlink(directory.path / each)


def test_a_client_uses_no_directory_that_is_not_its_own_and_private(tmp_path: Path):
    public = tmp_path / "public.segments"
    public.mkdir(mode=0o755)
    os.chmod(public, 0o755)
    assert shared_memory.SharedMemory(str(tmp_path / "public")).segment([b"x"]) is None
    assert shared_memory.SharedMemory(str(tmp_path / "missing")).segment([b"x"]) is None
    assert os.listdir(public) == []


def test_a_room_that_cannot_grow_leaves_the_answer_to_a_file_of_the_service(
    directory: SegmentDirectory, monkeypatch
):
    """When the client's room cannot grow (ENOSPC), the answer goes into an answer file of
    the service, linked in the room's place; the client copies it out and keeps its room."""
    client = shared_memory.SharedMemory(_socket_of(directory))
    q = np.random.default_rng(8).normal(size=(300, 7))
    segment = client.segment(binary.encode_parts({"q": q}))
    assert segment is not None and segment.room is not None
    served = RequestSegment(directory, segment.name, segment.length, 1 << 24, segment.room)
    real = os.posix_fallocate

    def room_full(fd: int, offset: int, length: int) -> None:
        if fd == served._room_fd:
            raise OSError(28, "No space left on device")
        real(fd, offset, length)

    monkeypatch.setattr(os, "posix_fallocate", room_full)
    assert served.answer_arrays({"tau": (300, 7)}) is None  # (computed in new memory)
    header = served.write_answer(binary.encode_parts({"tau": q * 5}))
    monkeypatch.setattr(os, "posix_fallocate", real)
    served.end()
    segment.settled = True
    content = segment.answer(header, 200)
    assert np.array_equal(binary.decode(content)[1]["tau"], q * 5)
    assert len([n for n in os.listdir(directory.path) if n.startswith("s-")]) == 1
    segment.release()
    rooms = [n for n in os.listdir(directory.path) if n.startswith("c-")]
    assert len(rooms) == 2  # the body file and the room, kept for the next request
    client.close()


def test_an_answer_computed_in_the_room_is_written_with_its_header_only(
    directory: SegmentDirectory,
):
    """`answer_arrays` gives arrays in the client's room: the answer computed into them is
    its header alone, no file of the service's is used, and the client's arrays are the
    room's memory (what the service wrote after the header, the client sees)."""
    client = shared_memory.SharedMemory(_socket_of(directory))
    q = np.random.default_rng(9).normal(size=(400, 7))
    segment = client.segment(binary.encode_parts({"q": q}))
    assert segment is not None and segment.room is not None
    served = RequestSegment(directory, segment.name, segment.length, 1 << 24, segment.room)
    arrays = served.answer_arrays({"tau": (400, 7)})
    assert arrays is not None
    arrays["tau"][:] = q * 7
    assert AnswerWriter(served).header_only(arrays)
    header = served.write_answer(binary.encode_parts(arrays))
    assert header.endswith(f" {HEADER_ROOM + q.nbytes}")
    served.end()
    segment.settled = True
    tau = binary.decode(segment.answer(header, 200))[1]["tau"]
    assert np.array_equal(tau, q * 7)
    arrays["tau"][0, 0] = -1.0  # (the service's mapping of the room: the same memory)
    assert tau[0, 0] == -1.0
    assert not [n for n in os.listdir(directory.path) if n.startswith("s-")]
    segment.release()
    client.close()


def test_no_room_anywhere_for_an_answer_is_overloaded(
    directory: SegmentDirectory, monkeypatch, no_rooms: None
):
    """When the memory file system is full (no file can grow), writing the answer is a 503
    `Overloaded` (clients retry it), not a server error; nothing is left linked."""
    from service.errors import Overloaded

    client = shared_memory.SharedMemory(_socket_of(directory))
    segment = client.segment(binary.encode_parts({"q": np.zeros((300, 7))}))
    assert segment is not None
    served = RequestSegment(directory, segment.name, segment.length, 1 << 24)

    def full(*args: object) -> int:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "posix_fallocate", full)
    monkeypatch.setattr(os, "pwritev", full)
    with pytest.raises(Overloaded, match="no room for the answer"):
        AnswerWriter(served)({"tau": np.ones((300, 7))})
    assert not os.path.lexists(directory.path / (segment.name + ".answer"))
    served.end()
    segment.release()
    client.close()
