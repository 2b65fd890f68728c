"""Running an upload's validation and build in an isolated builder process.

`build_upload` validates an uploaded description (robodyn's own checks: pure-Python XML work
that would hold the serving process's GIL for seconds on a large file), expands a xacro
(`service.registry.xacro_expand`) and builds the model (`service.registry.build`: Pinocchio's
URDF parser, or MuJoCo's compiler for MJCF), all in a separate short-lived process forked from
a forkserver that has Pinocchio, MuJoCo and the builders imported (`service.processes`, with
`FORKSERVER_PRELOAD`). It brings back what validation found, what the format adds (an MJCF's
visuals, a xacro's expansion) and the model in Pinocchio's binary serialization
(`build_isolated`: the model only). The child limits itself before it reads the text
(`service.processes.ResourceLimits`): address space (`RLIMIT_AS`, memory_mb), CPU time
(`RLIMIT_CPU`, cpu_s: SIGXCPU, then SIGKILL one second later), a lower CPU priority (nice 10),
no core files, few file descriptors, and no file writes from just before the native parser runs
(a xacro's assets and MuJoCo's empty working directory are written just before); the parent
adds a wall-clock timeout. A crash, a memory blow-up, a CPU limit or a hang of the native
parser becomes `InvalidModel` with a reason; the serving process never sees it. What the
server's condition causes, not the model, is `Overloaded` (503): a wall-clock timeout of a
child that got less than half of that time on a CPU, and a builder killed by SIGKILL from
outside (the kernel's OOM killer: `ChildDied.killed_from_outside`). How many builds run at
once is bounded by the caller (`service.registry.build_slots`).
"""

from __future__ import annotations

import signal
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import pinocchio as pin

from service.errors import InvalidModel, Overloaded
from service.processes import (
    ChildDied,
    ChildNotStarted,
    ChildTimedOut,
    ResourceLimits,
    forbid_file_writes,
    killed_detail,
    run_child,
    starved,
)
from service.registry.asset_checks import asset_report, check_asset_texts
from service.registry.build import (
    FORMATS,
    Checked,
    build_mjcf_model,
    build_urdf_model,
    check_mass_matrix,
    check_moves,
    check_subtree_masses,
    validate_urdf,
)
from service.registry.mjcf_compile import empty_working_directory, parse_xml, preflight
from service.registry.urdf_check import Limits
from service.registry.xacro_expand import expand_xacro, xacro_workspace


@dataclass(frozen=True)
class Built:
    """The result of `build_upload`: what validation found and the model (None when the
    findings were to be rejected, so nothing was built)."""

    checked: Checked
    model: Any | None
    report: dict[str, Any] = field(default_factory=dict)  # what the format adds (see _child_build)


FORKSERVER_PRELOAD = ("pinocchio", "numpy", "mujoco", __name__)
"""Modules the forkserver imports once (`service.processes.contexts`): each builder starts
with them loaded. The other forked children (upload bodies, the equations) name the same."""

BUILDER_OPEN_FILES = 64


def _child_build(
    conn: Any,
    text: str,
    root_joint: str,
    gravity: list[float] | None,
    description_format: str = "urdf",
    memory_mb: int = 1024,
    max_nv: int | None = None,
    limits: Limits | None = None,
    reject_findings: bool = False,
    assets: Mapping[str, bytes] | None = None,
    xacro_args: Mapping[str, str] | None = None,
) -> None:
    """The builder process (its limits already set by `service.processes`): validate, then
    (unless findings are to be rejected) build. Answers ("ok", Checked, model bytes, report),
    ("checked", Checked) or ("invalid", detail); the report holds what a format adds (MJCF:
    `MJCFModel.report`; xacro: its expansion)."""
    try:
        limits = limits or Limits()
        report: dict[str, Any] = {}
        description, urdf = text, None
        check_asset_texts(assets or {}, limits)
        if description_format == "xacro":
            parse_xml(text, "the xacro", limits)
            # its assets are written to a private directory, the only files it may read
            with xacro_workspace(text, assets or {}) as root_file:
                text = expand_xacro(root_file, xacro_args or {})
            report["expanded_urdf"] = text
        if description_format == "mjcf":
            label = preflight(text, assets or {}, limits)
            with empty_working_directory():  # created before file writes are forbidden
                forbid_file_writes()
                built = build_mjcf_model(text, root_joint, gravity, assets)
            model, report = built.model, {**report, **built.report()}
            checked = Checked(built.findings, built.notes, label, built.root_joint)
            if checked.findings and reject_findings:
                conn.send(("checked", checked))
                return
        else:  # URDF, or the URDF a xacro expanded to
            urdf = text
            checked = validate_urdf(text, root_joint, limits)
            if checked.findings and reject_findings:
                conn.send(("checked", checked))
                return
            forbid_file_writes()
            model = build_urdf_model(text, root_joint, gravity)
        if max_nv is not None and model.nv > max_nv:
            # before createData: its memory grows with nv³
            raise InvalidModel(
                f"the model has nv = {model.nv} velocity coordinates (with its "
                f"root joint); the limit is {max_nv} (ROBODYN_MAX_NV)"
            )
        check_moves(model)
        if description_format == "mjcf":
            check_subtree_masses(model)  # URDF uploads are checked on the text (urdf_check)
        check_mass_matrix(model)
        report.update(asset_report(description_format, description, urdf, assets or {}))
        conn.send(("ok", checked, model_to_binary(model), report))
    except InvalidModel as exc:
        conn.send(("invalid", exc.detail))
    except MemoryError:
        conn.send(
            (
                "invalid",
                f"building the model needed more than its memory limit of "
                f"{memory_mb} MB (ROBODYN_BUILD_MEMORY_MB)",
            )
        )
    except Exception:  # the parser's own messages carry C++ paths: never forward them
        conn.send(("invalid", _native_failure(description_format, memory_mb)))
    finally:
        conn.close()


def _native_failure(description_format: str, memory_mb: int) -> str:
    """What failed, for an exception of the native builder that is not ours (its own message
    is never forwarded): MuJoCo for an MJCF (its compiler, or an allocation it could not
    make), Pinocchio's URDF parser otherwise."""
    if description_format == "mjcf":
        return (
            "MuJoCo could not build a model from this MJCF (e.g. an allocation it could "
            f"not make within the builder's memory limit of {memory_mb} MB, "
            "ROBODYN_BUILD_MEMORY_MB)"
        )
    return "Pinocchio could not build a model from this description"


def _death(died: ChildDied, memory_mb: int, cpu_s: int) -> Exception:
    """The error of a builder child that ended without an answer: `Overloaded` when it was
    killed from outside (e.g. the OOM killer), else `InvalidModel` saying why."""
    if died.killed_from_outside(cpu_s):
        return Overloaded(killed_detail("the model builder", died.exitcode))
    return InvalidModel(_death_reason(died.exitcode, memory_mb, cpu_s))


def _death_reason(exitcode: int | None, memory_mb: int, cpu_s: int) -> str:
    """Why the builder child ended without an answer, for the user."""
    if exitcode is not None and exitcode < 0:
        sig = -exitcode
        if sig == signal.SIGXCPU or sig == signal.SIGKILL:  # SIGKILL: the CPU limit's hard one
            return (
                f"building the model was stopped: it used more than its CPU limit of "
                f"{cpu_s} s (ROBODYN_BUILD_CPU_S)"
            )
        if sig == signal.SIGSEGV:
            return (
                "the native model builder crashed on this description (segmentation fault, "
                "e.g. a stack overflow on a very long chain)"
            )
        name = signal.Signals(sig).name if sig in signal.valid_signals() else str(sig)
        return f"the native model builder crashed on this description (signal {name})"
    if exitcode not in (None, 0):  # e.g. std::bad_alloc → abort, or Python could not start
        return (
            f"the native model builder failed on this description (it may have needed more "
            f"than its memory limit of {memory_mb} MB, ROBODYN_BUILD_MEMORY_MB)"
        )
    return "the native model builder ended without an answer on this description"


def model_to_binary(model: Any) -> bytes:
    """The model in Pinocchio's binary serialization (what the builder process sends back)."""
    buffer = pin.serialization.StreamBuffer()
    model.saveToBinary(buffer)
    return bytes(buffer.tobytes())


def model_from_binary(raw: bytes) -> Any:
    """A `pin.Model` from `model_to_binary`'s bytes. Through a private temporary file: the
    binding reads binary archives from files or its own buffers only. The native load holds
    the GIL, and the binary form loads ~10× faster than the text form `pickle` uses (10 ms
    instead of 110 ms for a model of 15,000 frames), so the serving process keeps answering."""
    with tempfile.NamedTemporaryFile(prefix="robodyn-model-", suffix=".bin") as fh:
        fh.write(raw)
        fh.flush()
        model = pin.Model()
        model.loadFromBinary(fh.name)
    return model


def _timed_out(cpu_s: float | None, timeout_s: float) -> Exception:
    """The error of a builder that gave no answer within `timeout_s` after `cpu_s` seconds of
    CPU: `Overloaded` when it was starved of CPU (`service.processes.starved`), else
    `InvalidModel`."""
    if starved(cpu_s, timeout_s):
        return Overloaded(
            f"building the model got only {cpu_s:.1f} s of CPU time in its "
            f"{timeout_s:g} s (ROBODYN_BUILD_TIMEOUT_S): the server is too busy "
            "right now; retry shortly"
        )
    return InvalidModel(
        f"building the model took longer than {timeout_s:g} s (ROBODYN_BUILD_TIMEOUT_S)"
    )


def build_isolated(
    text: str,
    root_joint: str,
    gravity: list[float] | None,
    timeout_s: float,
    *,
    description_format: str = "urdf",
    memory_mb: int = 1024,
    cpu_s: int = 20,
    max_nv: int | None = None,
    limits: Limits | None = None,
    assets: Mapping[str, bytes] | None = None,
    xacro_args: Mapping[str, str] | None = None,
) -> Any:
    """Validate and build a URDF, MJCF or xacro model in a resource-limited child process
    (`build_upload`, findings reported, not rejected): the model."""
    return build_upload(
        text,
        root_joint,
        gravity,
        timeout_s,
        description_format=description_format,
        memory_mb=memory_mb,
        cpu_s=cpu_s,
        max_nv=max_nv,
        limits=limits,
        assets=assets,
        xacro_args=xacro_args,
    ).model


def build_upload(
    text: str,
    root_joint: str,
    gravity: list[float] | None,
    timeout_s: float,
    *,
    description_format: str = "urdf",
    memory_mb: int = 1024,
    cpu_s: int = 20,
    max_nv: int | None = None,
    limits: Limits | None = None,
    reject_findings: bool = False,
    assets: Mapping[str, bytes] | None = None,
    xacro_args: Mapping[str, str] | None = None,
) -> Built:
    """Validate (with the caps of `limits`) and build a description in a resource-limited
    child process: URDF, MJCF (compiled by MuJoCo with its `assets` in memory) or xacro
    (expanded there first with `xacro_args`, `service.registry.xacro_expand`). With
    `reject_findings`, a description with physical findings is not built (`Built.model` is
    None).

    Raises `InvalidModel` (with the reason, never a C++ message) on an invalid description, a
    crash of the child, a memory or CPU limit, or after `timeout_s` seconds of wall clock (the
    child is then killed) — unless the child was starved of CPU in that time, or killed from
    outside (SIGKILL not of its limits, e.g. the OOM killer): `Overloaded`.
    """
    if description_format not in FORMATS:
        raise ValueError(f"description_format must be one of {FORMATS}")
    try:
        answer = run_child(
            _child_build,
            (
                text,
                root_joint,
                gravity,
                description_format,
                memory_mb,
                max_nv,
                limits,
                reject_findings,
                assets,
                xacro_args,
            ),
            timeout_s=timeout_s,
            limits=ResourceLimits(memory_mb=memory_mb, cpu_s=cpu_s, open_files=BUILDER_OPEN_FILES),
            preload=FORKSERVER_PRELOAD,
        )
    except ChildNotStarted:  # no processes or descriptors left: the server's condition
        raise Overloaded("could not start a model builder process; retry shortly") from None
    except ChildTimedOut as exc:
        raise _timed_out(exc.cpu_s, timeout_s) from None
    except ChildDied as exc:
        raise _death(exc, memory_mb, cpu_s) from None
    if answer[0] == "invalid":
        raise InvalidModel(answer[1])
    if answer[0] == "checked":
        return Built(answer[1], None)
    return Built(answer[1], model_from_binary(answer[2]), answer[3])
