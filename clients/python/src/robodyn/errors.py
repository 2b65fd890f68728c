"""Exceptions of the robodyn client: one tree, one class per server error `code`.

Every error the server answers is RFC 9457 problem+json with a stable `code`; the client raises
the class named after that code. Classes also subclass the builtin that fits, so code that knows
nothing of robodyn can still catch them (`except LookupError`, `except ValueError`, ...)::

    RobodynError                                  anything raised by this package
    ├── InputError (ValueError)                   arguments rejected locally, nothing was sent
    ├── TransportError                            no HTTP answer: refused, reset, bad protocol
    │   └── TimeoutError (builtins.TimeoutError)  connect, read, write or pool timeout
    ├── ResponseFormatError                       a success answer the client cannot read
    └── APIError                                  the server answered with an error status
        ├── BadRequestError                       400 bad_request
        ├── UnauthorizedError (PermissionError)   401 unauthorized
        ├── NotFoundError (LookupError)           404 not_found (no such route)
        │   ├── RobotNotFoundError                404 robot_not_found
        │   └── AssetNotFoundError                404 asset_not_found
        ├── MethodNotAllowedError                 405 method_not_allowed
        ├── ConflictError                         409
        │   └── CatalogRobotError                 409 catalog_robot
        ├── PayloadTooLargeError (ValueError)     413 payload_too_large
        ├── UnsupportedMediaTypeError             415 unsupported_media_type
        ├── UnprocessableError (ValueError)       422
        │   ├── ValidationError                   422 validation_error
        │   ├── DimensionMismatchError            422 dimension_mismatch
        │   ├── InvalidConfigurationError         422 invalid_configuration
        │   ├── InvalidModelError                 422 invalid_model
        │   ├── UnknownFrameError (LookupError)   422 unknown_frame
        │   ├── SingularConfigurationError        422 singular_configuration
        │   ├── NonFiniteResultError (ArithmeticError)  422 non_finite_result
        │   ├── UnsupportedModelError             422 unsupported_model
        │   └── InfeasiblePathError               422 infeasible_path
        └── ServerError                           5xx
            ├── InternalServerError               500 internal_error
            ├── ServiceUnavailableError           503
            │   ├── NotReadyError                 503 not_ready
            │   └── OverloadedError               503 overloaded
            └── DeadlineExceededError (builtins.TimeoutError)  504 deadline_exceeded

A code this client does not know yet falls back by HTTP status to the class of that status in
the tree (a new 422 code raises `UnprocessableError`, a new 503 code `ServiceUnavailableError`,
any other 5xx `ServerError`, anything else `APIError`).
"""

from __future__ import annotations

import builtins
from typing import Any, ClassVar


class RobodynError(Exception):
    """Base of every exception raised by the robodyn client."""


class RobodynWarning(UserWarning):
    """The server computed the request as given, but its `Robodyn-Warning` answer header says
    an input looks like a mistake (an angle many turns outside its joint's range: degrees sent
    as radians). Turn it into an error with `warnings.simplefilter("error", RobodynWarning)`."""


class InputError(RobodynError, ValueError):
    """An argument was rejected by the client (not numeric, not finite, bad shape), before
    anything was sent; a large batch through shared memory is checked finite by the server
    first, and this is raised when the server refuses it."""


class TransportError(RobodynError):
    """The request got no HTTP answer (connection refused or reset, protocol error, ...).

    `method` and `url` name the request; the httpx exception is the `__cause__`.
    """

    def __init__(self, message: str, *, method: str = "", url: str = "") -> None:
        super().__init__(message)
        self.method = method
        self.url = url

    def __reduce__(self) -> tuple[Any, ...]:
        return (_rebuild, (type(self), str(self), {"method": self.method, "url": self.url}))


class TimeoutError(TransportError, builtins.TimeoutError):
    """The request timed out (connecting, sending, waiting for the answer, or for a connection)."""


class ResponseFormatError(RobodynError):
    """A success answer that is not what the API promises (not JSON, a field missing, ...)."""

    def __init__(self, message: str, *, status: int, body: Any = None) -> None:
        super().__init__(message)
        self.status = status
        self.body = body

    def __reduce__(self) -> tuple[Any, ...]:
        return (_rebuild, (type(self), str(self), {"status": self.status, "body": self.body}))


def _rebuild(cls: type[Exception], message: str, keywords: dict[str, Any]) -> Exception:
    return cls(message, **keywords)


class APIError(RobodynError):
    """The server answered with an error status.

    Attributes: `status` (HTTP status), `code` (the problem's stable machine-readable code, or
    None when the answer had none), `title`, `detail` (the human explanation), `body` (the decoded
    problem+json object, or the answer's text when it was not JSON) and `retry_after` (seconds,
    from the `Retry-After` header, or None).
    """

    status_code: ClassVar[int | None] = None  # the status this class stands for, if one
    error_code: ClassVar[str | None] = None  # the server code this class stands for, if one

    def __init__(
        self,
        status: int,
        code: str | None,
        title: str,
        detail: str,
        body: Any = None,
        retry_after: float | None = None,
    ) -> None:
        self.status = status
        self.code = code
        self.title = title
        self.detail = detail
        self.body = body
        self.retry_after = retry_after
        super().__init__(str(self))  # one message argument, also for the OSError subclasses

    def __str__(self) -> str:
        return f"{self.status} {self.code or self.title}: {self.detail}"

    def __reduce__(self) -> tuple[Any, ...]:  # picklable, e.g. across multiprocessing
        return (
            type(self),
            (self.status, self.code, self.title, self.detail, self.body, self.retry_after),
        )


class BadRequestError(APIError):
    status_code, error_code = 400, "bad_request"


class UnauthorizedError(APIError, PermissionError):
    """A missing or wrong API key: pass `api_key=` to the client."""

    status_code, error_code = 401, "unauthorized"


class NotFoundError(APIError, LookupError):
    status_code, error_code = 404, "not_found"


class RobotNotFoundError(NotFoundError):
    """No robot has this id; `robots()` lists the valid ones."""

    error_code = "robot_not_found"


class AssetNotFoundError(NotFoundError):
    """Not a mesh file the robot's visuals reference (GET /v1/robots/{id}/visuals lists the
    valid paths, its `asset` members)."""

    error_code = "asset_not_found"


class MethodNotAllowedError(APIError):
    status_code, error_code = 405, "method_not_allowed"


class ConflictError(APIError):
    status_code = 409


class CatalogRobotError(ConflictError):
    """Catalog robots cannot be deleted; only uploads can."""

    error_code = "catalog_robot"


class PayloadTooLargeError(APIError, ValueError):
    """The request body is over the server's limit: send smaller batches."""

    status_code, error_code = 413, "payload_too_large"


class UnsupportedMediaTypeError(APIError):
    status_code, error_code = 415, "unsupported_media_type"


class UnprocessableError(APIError, ValueError):
    """The server understood the request but its content cannot be used (422)."""

    status_code = 422


class ValidationError(UnprocessableError):
    """A malformed body, a missing field, a wrong type or a non-finite number."""

    error_code = "validation_error"


class DimensionMismatchError(UnprocessableError):
    """An array's length or batch size does not fit the robot (see `RobotInfo.nq`, `.nv`)."""

    error_code = "dimension_mismatch"


class InvalidConfigurationError(UnprocessableError):
    """A configuration q that is not valid, e.g. a quaternion that is not unit length."""

    error_code = "invalid_configuration"


class InvalidModelError(UnprocessableError):
    """An upload that is not a usable robot model; the detail names the element at fault."""

    error_code = "invalid_model"


class UnknownFrameError(UnprocessableError, LookupError):
    error_code = "unknown_frame"


class SingularConfigurationError(UnprocessableError):
    error_code = "singular_configuration"


class NonFiniteResultError(UnprocessableError, ArithmeticError):
    """The computed result is not finite (e.g. a moving body without mass)."""

    error_code = "non_finite_result"


class UnsupportedModelError(UnprocessableError):
    """The route needs what this model lacks (e.g. a fixed base and 1-DoF joints for
    identification or the equations in explicit form, or a size the derivation can finish in
    time); the detail says which."""

    error_code = "unsupported_model"


class InfeasiblePathError(UnprocessableError):
    """No timing can follow the path within the limits (retime); the problem's `joint`,
    `waypoint` and `path_fraction` say where (in `body`)."""

    error_code = "infeasible_path"


class ServerError(APIError):
    """A 5xx answer."""


class InternalServerError(ServerError):
    status_code, error_code = 500, "internal_error"


class ServiceUnavailableError(ServerError):
    """The service cannot answer now (503); retry after `retry_after` seconds."""

    status_code = 503


class NotReadyError(ServiceUnavailableError):
    error_code = "not_ready"


class OverloadedError(ServiceUnavailableError):
    error_code = "overloaded"


class DeadlineExceededError(ServerError, builtins.TimeoutError):
    """The computation stopped at the server's request deadline (504): ask for less work per
    request (fewer states or steps). Not retried: the same request would stop again."""

    status_code, error_code = 504, "deadline_exceeded"


def _tree(cls: type[APIError]) -> list[type[APIError]]:
    return [cls, *(c for sub in cls.__subclasses__() for c in _tree(sub))]


ERROR_BY_CODE: dict[str, type[APIError]] = {
    c.__dict__["error_code"]: c for c in _tree(APIError) if c.__dict__.get("error_code")
}
"""The class raised for each server `code`."""

ERROR_BY_STATUS: dict[int, type[APIError]] = {
    c.__dict__["status_code"]: c for c in _tree(APIError) if c.__dict__.get("status_code")
}
"""The class raised, by HTTP status, for an answer whose `code` this client does not know."""


def error_class(status: int, code: str | None) -> type[APIError]:
    """The exception class for an error answer: by `code`, else by `status`."""
    if code is not None and code in ERROR_BY_CODE:
        return ERROR_BY_CODE[code]
    if status in ERROR_BY_STATUS:
        return ERROR_BY_STATUS[status]
    return ServerError if 500 <= status <= 599 else APIError
