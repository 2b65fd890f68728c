"""Building Pinocchio models from description text (the only place the native parsers run).

`build_urdf_model` runs the native URDF parser on text that `urdf_check` has already validated,
`build_mjcf_model` MuJoCo's compiler on MJCF that `mjcf_compile.preflight` has checked.
`build_isolated` runs either in a separate short-lived process (forked from a forkserver that has
Pinocchio imported) and brings back the model serialized by Pinocchio itself. The child limits
itself before the native parser touches the text: address space (`RLIMIT_AS`, memory_mb), CPU
time (`RLIMIT_CPU`, cpu_s: SIGXCPU, then SIGKILL one second later), no core files, no file writes
(MuJoCo reads the assets from memory), few file descriptors; the parent adds a wall-clock
timeout. A crash, a kill, a memory blow-up or a hang of the native parser becomes `InvalidModel`
with a reason; the serving process never sees it.
"""

from __future__ import annotations

import multiprocessing as mp
import pickle
import resource
import signal
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from service.errors import InvalidModel, Overloaded
from service.registry.mjcf_build import MJCFModel, pinocchio_model
from service.registry.mjcf_compile import compile_mjcf, empty_working_directory
from service.registry.mjcf_visuals import mjcf_visuals
from service.registry.urdf_check import check_urdf
from service.registry.xacro_expand import expand_xacro, xacro_workspace

ROOT_JOINTS = ("fixed", "free-flyer", "planar")
FORMATS = ("urdf", "mjcf", "xacro")


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
    _set_gravity(model, gravity)
    return model


def _set_gravity(model: Any, gravity: Sequence[float] | None) -> None:
    if gravity is not None:
        model.gravity = pin.Motion(np.asarray(gravity, dtype=float), np.zeros(3))


def build_mjcf_model(text: str, root_joint: str, gravity: Sequence[float] | None = None,
                     assets: Mapping[str, bytes] | None = None) -> MJCFModel:
    """Compile MJCF text with MuJoCo (`mjcf_compile`, assets in memory) and build its Pinocchio
    model body by body (`mjcf_build`) and its visuals (`mjcf_visuals`); gravity defaults to the
    model's own."""
    mj = compile_mjcf(text, assets or {})
    built = pinocchio_model(mj, root_joint, gravity)
    built.visuals = mjcf_visuals(mj, built.body_frames)
    return built


def build_model(description_format: str, text: str, root_joint: str,
                gravity: Sequence[float] | None = None,
                assets: Mapping[str, bytes] | None = None) -> Any:
    """Build a model from validated URDF or MJCF text (`description_format`: "urdf"/"mjcf")."""
    if description_format == "mjcf":
        return build_mjcf_model(text, root_joint, gravity, assets).model
    if description_format == "urdf":
        return build_urdf_model(text, root_joint, gravity)
    raise ValueError(f"description_format must be one of {FORMATS}")


def reference_configurations(model: Any) -> dict[str, np.ndarray]:
    """The model's named configurations (MJCF keyframes and "qpos0"), normalized."""
    return {entry.key(): pin.normalize(model, np.array(entry.data(), dtype=float))
            for entry in model.referenceConfigurations}


def check_subtree_masses(model: Any) -> None:
    """Reject a model with a moving joint whose subtree carries no mass (M singular)."""
    data = model.createData()
    pin.computeSubtreeMasses(model, data)
    for jid in range(1, model.njoints):
        if model.joints[jid].nv and data.mass[jid] <= 0.0:
            raise InvalidModel(f"joint '{model.names[jid]}' moves a subtree without mass: the "
                               "mass matrix is singular")


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


def _limit_resources(memory_mb: int, cpu_s: int) -> None:
    """Resource limits of the builder child (Linux/Unix `setrlimit`; soft = hard)."""
    memory = memory_mb * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    resource.setrlimit(resource.RLIMIT_CPU, (cpu_s, cpu_s + 1))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
    resource.setrlimit(resource.RLIMIT_NOFILE, (64, 64))


def _child_build(conn: Any, text: str, root_joint: str, gravity: list[float] | None,
                 description_format: str = "urdf", memory_mb: int = 1024, cpu_s: int = 20,
                 max_nv: int | None = None, assets: Mapping[str, bytes] | None = None,
                 xacro_args: Mapping[str, str] | None = None) -> None:
    report: dict[str, Any] = {}
    try:
        if description_format == "xacro":
            with xacro_workspace(text, assets or {}) as root_file:  # written before the limits
                _limit_resources(memory_mb, cpu_s)
                urdf = expand_xacro(root_file, xacro_args or {})
            checked = check_urdf(urdf)
            model = build_urdf_model(urdf, root_joint, gravity)
            report = {"expanded_urdf": urdf, "robot_name": checked.robot_name,
                      "findings": [f.as_dict() for f in checked.findings]}
        elif description_format == "mjcf":
            with empty_working_directory():  # created before the limits forbid writes
                _limit_resources(memory_mb, cpu_s)
                built = build_mjcf_model(text, root_joint, gravity, assets)
            model, report = built.model, built.report()
        else:
            _limit_resources(memory_mb, cpu_s)
            model = build_urdf_model(text, root_joint, gravity)
        if max_nv is not None and model.nv > max_nv:
            # before createData: its memory grows with nv³
            raise InvalidModel(f"the model has nv = {model.nv} velocity coordinates (with its "
                               f"root joint); the limit is {max_nv} (ROBODYN_MAX_NV)")
        if description_format == "mjcf":
            check_subtree_masses(model)  # URDF uploads are checked on the text (urdf_check)
        check_mass_matrix(model)
        conn.send(("ok", pickle.dumps((model, report))))
    except InvalidModel as exc:
        conn.send(("invalid", exc.detail))
    except MemoryError:
        conn.send(("invalid", f"building the model needed more than its memory limit of "
                              f"{memory_mb} MB (ROBODYN_BUILD_MEMORY_MB)"))
    except Exception:  # the parser's own messages carry C++ paths: never forward them
        conn.send(("invalid", "Pinocchio could not build a model from this description"))
    finally:
        conn.close()


_context: Any = None


def _mp_context() -> Any:
    global _context
    if _context is None:
        _context = mp.get_context("forkserver")
        _context.set_forkserver_preload(["pinocchio", "numpy", "mujoco"])
    return _context


def _death(exitcode: int | None, memory_mb: int, cpu_s: int) -> str:
    """Why the builder child ended without an answer, for the user."""
    if exitcode is not None and exitcode < 0:
        sig = -exitcode
        if sig == signal.SIGXCPU or sig == signal.SIGKILL:
            return (f"building the model was stopped: it used more than its CPU limit of "
                    f"{cpu_s} s (ROBODYN_BUILD_CPU_S) or was killed")
        if sig == signal.SIGSEGV:
            return ("the native model builder crashed on this description (segmentation fault, "
                    "e.g. a stack overflow on a very long chain)")
        name = signal.Signals(sig).name if sig in signal.valid_signals() else str(sig)
        return f"the native model builder crashed on this description (signal {name})"
    if exitcode not in (None, 0):  # e.g. std::bad_alloc → abort, or Python could not start
        return (f"the native model builder failed on this description (it may have needed more "
                f"than its memory limit of {memory_mb} MB, ROBODYN_BUILD_MEMORY_MB)")
    return "the native model builder ended without an answer on this description"


def build_isolated(text: str, root_joint: str, gravity: list[float] | None,
                   timeout_s: float, *, description_format: str = "urdf",
                   memory_mb: int = 1024, cpu_s: int = 20, max_nv: int | None = None,
                   assets: Mapping[str, bytes] | None = None,
                   xacro_args: Mapping[str, str] | None = None,
                   report: dict[str, Any] | None = None) -> Any:
    """Build a URDF (or, with `description_format="mjcf"`, an MJCF with its `assets`) model in
    a resource-limited child process; with `"xacro"`, a xacro expanded there first with
    `xacro_args` (`xacro_expand`). `report` (if given) receives what the build found (MJCF:
    `MJCFModel.report`; xacro: the expanded URDF, its robot name and findings).

    Raises `InvalidModel` (with the reason, never a C++ message) on an invalid description, a
    crash or kill of the child, a memory or CPU limit, or after `timeout_s` seconds of wall
    clock; the child is then killed.
    """
    if description_format not in FORMATS:
        raise ValueError(f"description_format must be one of {FORMATS}")
    ctx = _mp_context()
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child_build, daemon=True,
                       args=(child, text, root_joint, gravity, description_format, memory_mb,
                             cpu_s, max_nv, assets, xacro_args))
    try:
        proc.start()
    except OSError:  # no processes or descriptors left: the server's condition, not the model's
        parent.close()
        raise Overloaded("could not start a model builder process; retry shortly") from None
    finally:
        child.close()
    try:
        if not parent.poll(timeout_s):
            raise InvalidModel(f"building the model took longer than {timeout_s:g} s "
                               "(ROBODYN_BUILD_TIMEOUT_S)")
        status, payload = parent.recv()
    except (EOFError, OSError):
        proc.join(5)
        raise InvalidModel(_death(proc.exitcode, memory_mb, cpu_s)) from None
    finally:
        parent.close()
        if proc.is_alive():
            proc.kill()
        proc.join(5)
    if status != "ok":
        raise InvalidModel(payload)
    model, found = pickle.loads(payload)
    if report is not None:
        report.update(found)
    return model
