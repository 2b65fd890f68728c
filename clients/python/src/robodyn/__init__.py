"""robodyn: the Python client of the robodyn rigid-body dynamics service.

    from robodyn import Client

    with Client("http://127.0.0.1:8000") as client:
        M = client.mass_matrix("ur5", q)        # numpy (nv, nv); (N, nv, nv) for q of shape (N, nq)

`Client` blocks, `AsyncClient` has the same methods as coroutines. Server errors raise the
subclass of `APIError` named after their `code` (see `robodyn.errors` for the tree).
Depends on httpx and numpy only.
"""

__version__ = "0.1.0"

from robodyn.async_client import AsyncClient
from robodyn.client import Client
from robodyn.errors import (
    APIError,
    AssetNotFoundError,
    BadRequestError,
    CatalogRobotError,
    ConflictError,
    DimensionMismatchError,
    InputError,
    InternalServerError,
    InvalidConfigurationError,
    InvalidModelError,
    MethodNotAllowedError,
    NonFiniteResultError,
    NotFoundError,
    NotReadyError,
    OverloadedError,
    PayloadTooLargeError,
    ResponseFormatError,
    RobodynError,
    RobotNotFoundError,
    ServerError,
    ServiceUnavailableError,
    SingularConfigurationError,
    TimeoutError,
    TransportError,
    UnauthorizedError,
    UnknownFrameError,
    UnprocessableError,
    UnsupportedMediaTypeError,
    ValidationError,
)
from robodyn.models import Finding, FrameInfo, JointInfo, RobotInfo, RobotList, RobotSummary
from robodyn.results import (
    BodyInertia,
    CenterOfMass,
    Centroidal,
    Energy,
    ForwardDynamicsDerivatives,
    FrameJacobian,
    Inertias,
    InverseDynamicsDerivatives,
    OperationalSpace,
    Trajectory,
)
from robodyn.stream import AsyncStream, Stream
from robodyn.transport import DEFAULT_TIMEOUT

__all__ = [
    "DEFAULT_TIMEOUT",
    "APIError",
    "AssetNotFoundError",
    "AsyncClient",
    "AsyncStream",
    "BadRequestError",
    "BodyInertia",
    "CatalogRobotError",
    "CenterOfMass",
    "Centroidal",
    "Client",
    "ConflictError",
    "DimensionMismatchError",
    "Energy",
    "Finding",
    "ForwardDynamicsDerivatives",
    "FrameInfo",
    "FrameJacobian",
    "Inertias",
    "InputError",
    "InternalServerError",
    "InvalidConfigurationError",
    "InvalidModelError",
    "InverseDynamicsDerivatives",
    "JointInfo",
    "MethodNotAllowedError",
    "NonFiniteResultError",
    "NotFoundError",
    "NotReadyError",
    "OperationalSpace",
    "OverloadedError",
    "PayloadTooLargeError",
    "ResponseFormatError",
    "RobodynError",
    "RobotInfo",
    "RobotList",
    "RobotNotFoundError",
    "RobotSummary",
    "ServerError",
    "ServiceUnavailableError",
    "SingularConfigurationError",
    "Stream",
    "TimeoutError",
    "Trajectory",
    "TransportError",
    "UnauthorizedError",
    "UnknownFrameError",
    "UnprocessableError",
    "UnsupportedMediaTypeError",
    "ValidationError",
    "__version__",
]
