"""Domain errors of robodyn, each with a stable machine-readable `code`.

No HTTP in here: the one code → status table lives in `service.api.problems.handlers`; the one
builder of an error's RFC 9457 problem+json object is `problem_document` (used by the API and by
the HTTP protocol of `service.server`, which answers before any application). Every message is
written for the user of the service: it says what was expected, never echoes raw input values
that could be huge or non-finite, and never carries a backend path or C++ source location.

    RobodynError                      code
    ├── RobotNotFound                 robot_not_found
    ├── AssetNotFound                 asset_not_found
    ├── CatalogRobot                  catalog_robot
    ├── InvalidInput                  validation_error
    ├── DimensionMismatch             dimension_mismatch
    ├── InvalidConfiguration          invalid_configuration
    ├── InvalidModel                  invalid_model
    ├── UnknownFrame                  unknown_frame
    ├── SingularConfiguration         singular_configuration
    ├── NonFiniteResult               non_finite_result
    ├── UnsupportedModel              unsupported_model
    ├── PayloadTooLarge               payload_too_large
    ├── Unauthorized                  unauthorized
    ├── NotReady                      not_ready
    ├── Overloaded                    overloaded
    │   └── ComputationStopped        overloaded
    ├── DeadlineExceeded              deadline_exceeded
    ├── UnsupportedMediaType          unsupported_media_type
    └── InfeasiblePath                infeasible_path
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from typing import Any, ClassVar

MAX_DETAIL_CHARS = 4000
_SUGGESTED_NAME_CHARS = 64  # a name longer than this (or unprintable) gets no suggestion


def did_you_mean(
    name: str, valid: Iterable[str], most: int = 3, longest: int = _SUGGESTED_NAME_CHARS
) -> str:
    """ " (did you mean 'tool0'?)" when `valid` has names close to the unknown `name` (the
    names equal to it but for case first, then by difflib's similarity ratio ≥ 0.6 of the
    lower-cased names, best first, at most `most`), else "". Meant to follow the quoted
    unknown name in an error's detail."""
    if not name or len(name) > longest or not name.isprintable():
        return ""
    by_lower: dict[str, list[str]] = {}
    for candidate in valid:
        by_lower.setdefault(candidate.lower(), []).append(candidate)
    lower = name.lower()
    close = list(by_lower.get(lower, []))
    for match in difflib.get_close_matches(lower, list(by_lower), n=most, cutoff=0.6):
        close.extend(c for c in by_lower[match] if c not in close)
    close = close[:most]
    if not close:
        return ""
    quoted = [f"'{c}'" for c in close]
    shown = quoted[0] if len(quoted) == 1 else f"{', '.join(quoted[:-1])} or {quoted[-1]}"
    return f" (did you mean {shown}?)"


def problem_document(
    code: str, title: str, status: int, detail: str, **extra: Any
) -> dict[str, Any]:
    """The RFC 9457 problem details object of an error answer, with its stable `code` (and
    `extra` members, e.g. `errors` or `largest_batch`). A `detail` longer than
    `MAX_DETAIL_CHARS` is cut (its names are shortened where it is written; this is the net)."""
    if len(detail) > MAX_DETAIL_CHARS:
        detail = detail[:MAX_DETAIL_CHARS] + "…"
    return {
        "type": "about:blank",
        "title": title,
        "status": status,
        "detail": detail,
        "code": code,
        **extra,
    }


class RobodynError(Exception):
    """Base of all domain errors: a stable `code`, a short `title` and a human `detail`."""

    code: ClassVar[str] = "internal_error"
    title: ClassVar[str] = "Internal error"

    def __init__(self, detail: str, **extra: Any) -> None:
        super().__init__(detail)
        self.detail = detail
        self.extra = extra


class RobotNotFound(RobodynError):
    code = "robot_not_found"
    title = "Robot not found"


class AssetNotFound(RobodynError):
    """A path that is not one of the mesh files a robot's visuals reference."""

    code = "asset_not_found"
    title = "Asset not found"


class CatalogRobot(RobodynError):
    code = "catalog_robot"
    title = "Catalog robots cannot be deleted"


class InvalidInput(RobodynError):
    code = "validation_error"
    title = "Invalid request"


class DimensionMismatch(RobodynError):
    code = "dimension_mismatch"
    title = "Dimension mismatch"


class InvalidConfiguration(RobodynError):
    code = "invalid_configuration"
    title = "Invalid configuration"


class InvalidModel(RobodynError):
    code = "invalid_model"
    title = "Invalid robot model"


class UnknownFrame(RobodynError):
    code = "unknown_frame"
    title = "Unknown frame"


class SingularConfiguration(RobodynError):
    code = "singular_configuration"
    title = "Singular configuration"


class NonFiniteResult(RobodynError):
    code = "non_finite_result"
    title = "Non-finite result"


class UnsupportedModel(RobodynError):
    """The route needs what this model lacks: e.g. a fixed base and 1-DoF joints for
    identification and for the equations of motion in explicit form, or a size their
    derivation can finish in time, or joints that are all revolute or prismatic for retiming."""

    code = "unsupported_model"
    title = "Unsupported model"


class PayloadTooLarge(RobodynError):
    code = "payload_too_large"
    title = "Payload too large"


class Unauthorized(RobodynError):
    code = "unauthorized"
    title = "Unauthorized"


class NotReady(RobodynError):
    code = "not_ready"
    title = "Not ready"


class Overloaded(RobodynError):
    code = "overloaded"
    title = "Overloaded"


class ComputationStopped(Overloaded):
    """A long computation stopped by its caller's `should_stop` (the client went away, or
    the request's deadline passed) before it finished."""

    title = "Computation stopped"


class DeadlineExceeded(RobodynError):
    """A long computation stopped at the request's deadline (ROBODYN_REQUEST_DEADLINE_S).
    Not `overloaded`: the same request would stop again, so clients do not retry it."""

    code = "deadline_exceeded"
    title = "Deadline exceeded"


class UnsupportedMediaType(RobodynError):
    code = "unsupported_media_type"
    title = "Unsupported media type"


class InfeasiblePath(RobodynError):
    """No timing can follow the geometric path within the limits; `extra` names the joint
    (`joint`), the waypoint the path segment starts at (`waypoint`) and the path fraction
    (`path_fraction`, 0 at the first waypoint, 1 at the last)."""

    code = "infeasible_path"
    title = "Infeasible path"


ALL_ERRORS: tuple[type[RobodynError], ...] = (
    RobotNotFound,
    AssetNotFound,
    CatalogRobot,
    InvalidInput,
    DimensionMismatch,
    InvalidConfiguration,
    InvalidModel,
    UnknownFrame,
    SingularConfiguration,
    NonFiniteResult,
    UnsupportedModel,
    PayloadTooLarge,
    Unauthorized,
    NotReady,
    Overloaded,
    DeadlineExceeded,
    UnsupportedMediaType,
    InfeasiblePath,
)
