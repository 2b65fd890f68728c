"""Benchmark row 7: a payload-capacity batch through the client against an in-process Python loop.

The loop is what a user of Pinocchio writes in process for the same answer: per state, RNEA of
the robot and of the robot holding 1 kg more at the point (their difference is τ₁, the torques
per kg: τ is affine in the mass), then the largest mass each limited joint allows and the
minimum over joints. The models are built once, outside the timing, as the service caches them.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

FRAME, COM = "tool0", [0.0, 0.0, 0.05]


def ur5_states(n: int, seed: int = 3) -> tuple[object, dict[str, np.ndarray]]:
    import tempfile

    import pinocchio as pin

    from service.registry import Registry

    registry = Registry(tempfile.mkdtemp(), ["ur5"])
    registry.load()
    model = registry.get("ur5").model
    rng = np.random.default_rng(seed)
    q = np.array([pin.randomConfiguration(model) for _ in range(n)])
    return model, {
        "q": q,
        "v": rng.normal(0, 1, (n, model.nv)),
        "a": rng.normal(0, 1, (n, model.nv)),
    }


def python_loop(model: object, s: dict[str, np.ndarray]) -> Callable[[], float]:
    """The timed in-process loop (seconds per call of the returned function)."""
    import pinocchio as pin

    data = model.createData()  # type: ignore[attr-defined]
    heavier = pin.Model(model)
    frame = heavier.frames[heavier.getFrameId(FRAME)]
    heavier.inertias[frame.parentJoint] += frame.placement.act(
        pin.Inertia(1.0, np.array(COM), np.zeros((3, 3)))
    )
    heavier_data = heavier.createData()
    limit = np.array(model.effortLimit)  # type: ignore[attr-defined]
    q, v, a = s["q"], s["v"], s["a"]

    def loop() -> float:
        t = time.perf_counter()
        mass = np.empty(q.shape[0])
        joint = np.empty(q.shape[0], dtype=int)
        for i in range(q.shape[0]):
            tau0 = pin.rnea(model, data, q[i], v[i], a[i])
            tau1 = pin.rnea(heavier, heavier_data, q[i], v[i], a[i]) - tau0
            with np.errstate(divide="ignore", invalid="ignore"):
                per = np.where(tau1 > 0, (limit - tau0) / tau1, (limit + tau0) / -tau1)
            per = np.where(np.abs(tau0) > limit, 0.0, np.where(tau1 == 0, np.inf, per))
            joint[i] = int(np.argmin(per))
            mass[i] = per[joint[i]]
        return time.perf_counter() - t

    return loop


def payload_capacity(
    url: str,
    rounds: int,
    median_of: Callable[[int, Callable[[], float]], float],
    row: Callable[..., None],
) -> None:
    import robodyn

    print("7. payload-capacity batch (UR5, a point mass at tool0, moving)", flush=True)
    n = 2000
    model, s = ur5_states(n)
    loop_seconds = median_of(rounds, python_loop(model, s))
    with robodyn.Client(url, timeout=300) as client:

        def served() -> float:
            t = time.perf_counter()
            client.payload_capacity("ur5", s["q"], FRAME, center_of_mass=COM, v=s["v"], a=s["a"])
            return time.perf_counter() - t

        served()  # the first request builds the unit-mass model: not what is measured
        row(
            f"payload-capacity batch of {n} (UR5, moving) via client vs in-process Python loop "
            "(two RNEA per state)",
            n / median_of(rounds, served),
            n / loop_seconds,
            "states/s",
            "≥ 1.0",
        )
