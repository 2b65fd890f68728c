"""Doing to a child of `service.processes` what the machine does from outside (the kernel's OOM
killer's SIGKILL, an operator's SIGSTOP) while a call waits for it, for the tests of its
callers (builders, upload bodies, the equations)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from service.processes import live_children

START_S = 60.0  # the call starts its child within this
END_S = 120.0  # and ends within this once it is acted on


def raised_when_its_child(during: Callable[[], Any], act: Callable[[int], None]) -> Exception:
    """What `during()` raises when `act(pid)` is done to the child process it starts (the
    first child started after the call)."""
    before = {proc.pid for proc in live_children()}
    raised: list[Exception] = []

    def run() -> None:
        try:
            during()
        except Exception as exc:
            raised.append(exc)

    thread = threading.Thread(target=run)
    thread.start()
    deadline = time.monotonic() + START_S
    while not (started := [p for p in live_children() if p.pid not in before]):
        assert thread.is_alive() and time.monotonic() < deadline, raised or "no child started"
        time.sleep(0.005)
    act(int(started[0].pid))  # type: ignore[arg-type]
    thread.join(END_S)
    assert len(raised) == 1, raised or "it answered anyway"
    return raised[0]
