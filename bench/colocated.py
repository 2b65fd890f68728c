"""Benchmark row 9: co-located clients, through the Unix socket and shared memory, beside TCP,
against the user's own in-process Pinocchio.

The same server serves both; each round times the socket client, the TCP client and the
in-process baseline one after the other (so the machine's load falls on all three alike), and
the rows are medians over the rounds:

- 10,000 Talos inverse-dynamics states against `pin.rneaInParallel` on 2 threads (a
  `ModelPool`, the inputs already column-major as it takes them), as called plainly (the
  answer a new array) and, as information, writing into an array allocated beforehand;
- 2,000 Talos mass matrices and 2,000 Coriolis matrices against a Python loop over `pin.crba` /
  `pin.computeCoriolisMatrix` with one Data, each answer copied out and stacked (the service's
  answer is one array too). `WARM_S` seconds of such batches come first: the first of them
  through the socket start the server's batch helpers (ROBODYN_BATCH_HELPERS: unset, one per
  CPU but one for the socket's requests; 0: off), which share these batches with the serving
  process.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

import numpy as np

Row = Callable[[str, float, float, str, str], None]
WARM_S = 10.0


def colocated(
    url: str, socket_path: str, rounds: int, states: Callable[..., tuple[object, dict]], row: Row
) -> None:
    import pinocchio as pin
    import robodyn

    print("9. co-located clients: the Unix socket and shared memory beside TCP", flush=True)
    model, s = states(10_000, seed=4)
    pool = pin.ModelPool(model, 2)
    qT, vT, aT = (np.asfortranarray(s[k].T) for k in ("q", "v", "a"))

    def rnea_in_parallel() -> None:
        pin.rneaInParallel(2, pool, qT, vT, aT)

    tau_out = np.empty((model.nv, 10_000), order="F")  # type: ignore[attr-defined]

    def rnea_into_preallocated() -> None:
        pin.rneaInParallel(2, pool, qT, vT, aT, tau_out)

    data = model.createData()  # type: ignore[attr-defined]
    n = 2000
    q, v = s["q"][:n], s["v"][:n]

    def crba_loop() -> None:
        np.stack([np.array(pin.crba(model, data, q[i])) for i in range(n)])

    def coriolis_loop() -> None:
        np.stack([np.array(pin.computeCoriolisMatrix(model, data, q[i], v[i])) for i in range(n)])

    with (
        robodyn.Client(f"unix://{socket_path}", timeout=300) as local,
        robodyn.Client(url, timeout=300) as remote,
    ):
        for name, call in (
            ("inverse_dynamics", lambda c: c.inverse_dynamics("talos", s["q"], s["v"], s["a"])),
            ("mass_matrix", lambda c: c.mass_matrix("talos", q)),
            ("coriolis", lambda c: c.coriolis("talos", q, v)),
        ):
            ours, theirs = call(local), call(remote)  # (warm-up, and the same answers)
            for a, b in zip(
                ours if isinstance(ours, tuple) else (ours,),
                theirs if isinstance(theirs, tuple) else (theirs,),
                strict=True,
            ):
                assert np.array_equal(a, b), f"{name}: socket and TCP answers differ"
        # The first large M and C batches through the socket start the server's batch
        # helpers, which import Pinocchio before they serve (seconds on a loaded machine):
        # warmed before timing.
        warm_until = time.monotonic() + WARM_S
        while time.monotonic() < warm_until:
            local.mass_matrix("talos", q)
            local.coriolis("talos", q, v)
        cases = [
            (
                "inverse dynamics, 10,000 Talos states",
                10_000,
                lambda c: c.inverse_dynamics("talos", s["q"], s["v"], s["a"]),
                rnea_in_parallel,
                "in-process rneaInParallel (2 threads)",
                "≥ 0.85",
            ),
            (
                "mass_matrix batch of 2000",
                n,
                lambda c: c.mass_matrix("talos", q),
                crba_loop,
                "in-process Python loop",
                "≥ 1.0",
            ),
            (
                "coriolis batch of 2000",
                n,
                lambda c: c.coriolis("talos", q, v),
                coriolis_loop,
                "in-process Python loop",
                "≥ 1.0",
            ),
        ]
        for what, count, call, baseline, against, target in cases:
            socket_s, tcp_s, base_s, into_s = [], [], [], []
            for _ in range(rounds):
                socket_s.append(_seconds(lambda call=call: call(local)))
                tcp_s.append(_seconds(lambda call=call: call(remote)))
                base_s.append(_seconds(baseline))
                if baseline is rnea_in_parallel:
                    into_s.append(_seconds(rnea_into_preallocated))
            base = count / statistics.median(base_s)
            row(
                f"{what} via Unix socket + shared memory vs {against}",
                count / statistics.median(socket_s),
                base,
                "states/s",
                target,
            )
            row(
                f"{what} via TCP (same run) vs {against}",
                count / statistics.median(tcp_s),
                base,
                "states/s",
                "info",
            )
            if into_s:  # the in-process call at its fastest: no answer array allocated
                row(
                    f"{what} via Unix socket + shared memory vs in-process rneaInParallel "
                    "into a preallocated array",
                    count / statistics.median(socket_s),
                    count / statistics.median(into_s),
                    "states/s",
                    "info",
                )


def _seconds(fn: Callable[[], object]) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t
