"""Bench: identify a 7-DoF arm (the catalog's panda, fingers locked) from a 20,000-sample log.

Prints the time of `identify` for both methods on a synthetic log (1 kHz, 20 s; v and a
missing, so the log is filtered and differentiated): the target is under 60 s on this
machine. Run from the repository root:

    PYTHONPATH=$PWD python bench/identification_panda.py
"""

from __future__ import annotations

import time

import numpy as np

from service.dynamics.identification import identify
from service.registry.catalog import load_catalog
from service.registry.reduce import reduced_robot
from tests.service.dynamics.identification_logs import synthetic_log


def panda_arm():
    """The catalog's panda with both finger joints locked at 0.02 m: 7 revolute joints."""
    panda = load_catalog(["panda"])[0]["panda"]
    locked = {"panda_finger_joint1": [0.02], "panda_finger_joint2": [0.02]}
    return reduced_robot(
        panda, locked, "panda_arm", "panda_arm", {"robot": "panda", "locked_joints": locked}
    )


def main() -> None:
    robot = panda_arm()
    log = synthetic_log(robot.model, seed=3, duration=20.0, rate=1000.0, noise=0.05)
    print(f"robot {robot.id}: nv = {robot.nv}, log of {log.t.size} samples")
    for method in ("least-squares", "physically-consistent"):
        start = time.perf_counter()
        result = identify(robot, log.t, log.q, log.tau, method=method)
        elapsed = time.perf_counter() - start
        print(
            f"{method:>22}: {elapsed:6.2f} s; validation RMSE max "
            f"{np.max(result.rmse['validation']):.4f} N·m (before "
            f"{np.max(result.rmse['validation_before']):.3f}); condition number "
            f"{result.condition_number:.4g}; physically consistent "
            f"{result.physically_consistent}"
        )


if __name__ == "__main__":
    main()
