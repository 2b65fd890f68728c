"""Building Pinocchio models from description text (the only place the native parsers run).

`build_urdf_model` runs the native URDF parser on text that `urdf_check` has already validated.
`build_isolated` runs it in a separate short-lived process (forked from a forkserver that has
Pinocchio imported) under a wall-clock timeout, and brings back the model serialized by Pinocchio
itself: a crash or a hang of the native parser on an upload never touches the serving process.
"""

from __future__ import annotations

import multiprocessing as mp
import pickle
from collections.abc import Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from service.errors import InvalidModel

ROOT_JOINTS = ("fixed", "free-flyer", "planar")


def root_joint_model(root_joint: str) -> Any | None:
    """The Pinocchio joint that attaches the description's root link to the world."""
    if root_joint == "fixed":
        return None
    if root_joint == "free-flyer":
        return pin.JointModelFreeFlyer()
    if root_joint == "planar":
        return pin.JointModelPlanar()
    raise ValueError(f"root_joint must be one of {ROOT_JOINTS}")


def build_urdf_model(text: str, root_joint: str, gravity: Sequence[float] | None = None) -> Any:
    """Parse validated URDF text into a `pin.Model` (kinematics and inertias; no geometry)."""
    joint = root_joint_model(root_joint)
    model = pin.buildModelFromXML(text) if joint is None else pin.buildModelFromXML(text, joint)
    if gravity is not None:
        model.gravity = pin.Motion(np.asarray(gravity, dtype=float), np.zeros(3))
    return model


def check_mass_matrix(model: Any) -> None:
    """Reject a model whose mass matrix at the neutral configuration is not positive definite."""
    data = model.createData()
    M = pin.crba(model, data, pin.neutral(model))
    M = np.triu(M) + np.triu(M, 1).T
    if not np.all(np.isfinite(M)):
        raise InvalidModel("the mass matrix at the neutral configuration is not finite")
    if model.nv and np.linalg.eigvalsh(M)[0] <= 0.0:
        raise InvalidModel("the mass matrix at the neutral configuration is not positive "
                           "definite (a moving body without mass or inertia)")


def _child_build(conn: Any, text: str, root_joint: str, gravity: list[float] | None) -> None:
    try:
        model = build_urdf_model(text, root_joint, gravity)
        check_mass_matrix(model)
        conn.send(("ok", pickle.dumps(model)))
    except InvalidModel as exc:
        conn.send(("invalid", exc.detail))
    except Exception:  # the parser's own messages carry C++ paths: never forward them
        conn.send(("invalid", "Pinocchio could not build a model from this description"))
    finally:
        conn.close()


_context: Any = None


def _mp_context() -> Any:
    global _context
    if _context is None:
        _context = mp.get_context("forkserver")
        _context.set_forkserver_preload(["pinocchio", "numpy"])
    return _context


def build_isolated(text: str, root_joint: str, gravity: list[float] | None,
                   timeout_s: float) -> Any:
    """Build a URDF model in a child process; raise `InvalidModel` on failure, crash or timeout."""
    ctx = _mp_context()
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child_build, args=(child, text, root_joint, gravity), daemon=True)
    proc.start()
    child.close()
    try:
        if not parent.poll(timeout_s):
            raise InvalidModel(f"building the model took longer than {timeout_s:g} s")
        status, payload = parent.recv()
    except EOFError:
        raise InvalidModel("the model builder crashed on this description") from None
    finally:
        parent.close()
        if proc.is_alive():
            proc.kill()
        proc.join(5)
    if status != "ok":
        raise InvalidModel(payload)
    return pickle.loads(payload)
