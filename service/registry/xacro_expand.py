"""xacro uploads expanded with ROS's own `xacro` package, confined, in the builder process only.

xacro expressions (`${...}`, `$(eval ...)`) are Python evaluated with few builtins, which is known
to be escapable (generator frames reach module globals). So the confinement does not rely on
xacro: in the builder process, `xacro_workspace` writes the upload's assets (and the xacro text as
`ROOT_FILE`) into a new private directory before the resource limits forbid writes, and
`expand_xacro` then clears the environment and installs an audit hook (PEP 578, irremovable) that
refuses, until the expansion returns, any file opened outside that directory or for writing,
every process, signal, socket, ctypes and file-system-changing operation, and any new import.
`$(find pkg)` resolves to `<directory>/pkg` when the assets hold files under `pkg/`, and is
refused otherwise; an include or YAML file named `package://pkg/x` is the asset `pkg/x`. The
expansion's memory, CPU and wall-clock time are those of the builder process. Whatever is
refused or fails is an `InvalidModel` naming it.
"""

from __future__ import annotations

import io
import os
import re
import sys
import tempfile
import xml.dom.expatbuilder
import xml.dom.minidom  # noqa: F401
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import xacro
import xacro.substitution_args
import yaml  # noqa: F401  (xacro's load_yaml imports it: before the audit hook)

from service.errors import InvalidModel

ROOT_FILE = ".robodyn-upload.xacro"
MAX_MESSAGE = 400
_REFUSED = (
    "os.system",
    "os.exec",
    "os.posix_spawn",
    "os.spawn",
    "os.fork",
    "os.forkpty",
    "os.kill",
    "os.killpg",
    "os.remove",
    "os.rename",
    "os.rmdir",
    "os.mkdir",
    "os.symlink",
    "os.link",
    "os.chmod",
    "os.chown",
    "os.truncate",
    "os.chdir",
    "os.listdir",
    "os.scandir",
    "os.putenv",
    "os.unsetenv",
    "os.chroot",
    "subprocess.",
    "socket.",
    "ctypes.",
    "mmap.",
    "shutil.",
    "sys.addaudithook",
    "pty.",
    "signal.",
    "resource.",
    "fcntl.",
    "winreg.",
    "urllib.",
    "http.",
    "ftplib.",
)
_WRITE_FLAGS = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_APPEND | os.O_TRUNC
_state: dict[str, Any] = {"root": None}


class Refused(Exception):
    """An operation the xacro expansion may not do."""


def _audit(event: str, args: tuple[Any, ...]) -> None:
    root = _state["root"]
    if root is None:
        return
    if event == "open":
        path, mode, flags = args
        if isinstance(path, int):
            return
        inside = os.path.realpath(os.path.join(root, os.fsdecode(path)))
        writing = (isinstance(mode, str) and any(c in mode for c in "wax+")) or (
            isinstance(flags, int) and flags & _WRITE_FLAGS
        )
        if writing or not inside.startswith(root + os.sep):
            raise Refused(
                f"opening '{_shown(os.fsdecode(path))}' (only the upload's assets can be read)"
            )
    elif event == "import":
        if args[0] not in sys.modules:  # no new code: only modules imported before
            raise Refused(f"importing {str(args[0])[:80]!r}")
    elif event.startswith(_REFUSED):
        raise Refused(f"the operation {event!r}")


_hooked = False
_abs_filename_spec = xacro.abs_filename_spec


def _filename(spec: str) -> str:
    """xacro's include and YAML paths, with `package://pkg/x` as the asset `pkg/x`."""
    if spec.startswith("package://"):
        return os.path.join(_state["root"] or ".", spec[len("package://") :])
    return str(_abs_filename_spec(spec))


def _find_in_assets(pkg: str) -> str:
    root = _state["root"]
    if (
        root is None
        or "/" in pkg
        or pkg in ("", ".", "..")
        or not os.path.isdir(os.path.join(root, pkg))
    ):
        raise Refused(f"$(find {_shown(pkg)}): no asset is under '{_shown(pkg)}/'")
    return os.path.join(root, pkg)


def _shown(text: str) -> str:
    root = _state["root"]
    if root:
        text = text.replace(root + os.sep, "").replace(root, ".")
    text = re.sub(r"/\S*robodyn-xacro-[^/\s]*/?", "", text)
    return text if len(text) <= MAX_MESSAGE else text[:MAX_MESSAGE] + "…"


@contextmanager
def xacro_workspace(text: str, assets: Mapping[str, bytes]) -> Iterator[Path]:
    """A new private directory holding `assets` (by key) and `text` as `ROOT_FILE`; the path
    of the root file. Enter it before the builder's limits forbid writes."""
    with tempfile.TemporaryDirectory(prefix="robodyn-xacro-") as tmp:
        root = Path(tmp).resolve()
        for key, data in assets.items():
            path = root / key
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
        (root / ROOT_FILE).write_text(text, encoding="utf-8")
        yield root / ROOT_FILE


def expand_xacro(root_file: Path, args: Mapping[str, str]) -> str:
    """The URDF text of the xacro at `root_file` (in `xacro_workspace`) with `args`, expanded
    under the confinement of the module docstring (only in the builder process: the audit hook
    stays installed for the life of the process)."""
    global _hooked
    os.environ.clear()  # $(env ...) and $(optenv ...) see nothing of the server's
    xacro.substitution_args._eval_find = _find_in_assets
    xacro.abs_filename_spec = _filename
    if not _hooked:
        sys.addaudithook(_audit)
        _hooked = True
    os.chdir(root_file.parent)  # xacro opens includes and YAML relative to the working directory
    _state["root"] = str(root_file.parent)
    sys.stdout = sys.stderr = io.StringIO()  # its messages (the process may not write files)
    try:
        doc = xacro.process_file(root_file.name, mappings=dict(args))
        return str(doc.toxml())
    except Exception as exc:  # xacro's own errors name the macro, property or file
        cause = _cause(exc)
        if isinstance(cause, Refused):
            raise InvalidModel(f"xacro was refused {cause}") from None
        if isinstance(cause, RecursionError):
            raise InvalidModel(
                "xacro: the expansion recursed too deeply (a macro or property "
                "that refers to itself?)"
            ) from None
        if isinstance(cause, MemoryError):
            raise MemoryError from None
        message = _shown(" ".join(str(exc).split())) or type(exc).__name__
        raise InvalidModel(f"xacro could not expand the description: {message}") from None
    finally:
        _state["root"] = None
        sys.stdout, sys.stderr = sys.__stdout__, sys.__stderr__


def _cause(exc: BaseException) -> BaseException:
    """The first refusal, recursion or memory error behind `exc` (xacro wraps errors)."""
    seen: list[BaseException] = []
    current: BaseException | None = exc
    while current is not None and current not in seen and len(seen) < 50:
        if isinstance(current, Refused | RecursionError | MemoryError):
            return current
        seen.append(current)
        wrapped = getattr(current, "exc", None)
        current = (
            wrapped
            if isinstance(wrapped, BaseException)
            else current.__cause__ or current.__context__
        )
    return exc
