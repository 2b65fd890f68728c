"""robodyn: the Python client of the robodyn rigid-body dynamics service.

    from robodyn import Client

    with Client("http://127.0.0.1:8000") as client:
        M = client.mass_matrix("ur5", q)        # numpy (nv, nv); (N, nv, nv) for q of shape (N, nq)

`Client` blocks, `AsyncClient` has the same methods as coroutines. Server errors raise the
subclass of `APIError` named after their `code` (see `robodyn.errors` for the tree); requests
a busy server could not answer are retried (`Retry`). Inputs are any array-like (numpy,
torch, JAX, lists) or keyed by joint name (mappings, ROS JointState-like objects); answers are
numpy arrays, or torch tensors with `Client(array_type="torch")`. Every computing method takes
`payloads=[Payload(frame, mass, ...)]`, rigid bodies the robot holds. Depends on httpx, numpy
and stamina.
"""

__version__ = "0.1.0"

from robodyn.async_client import AsyncClient
from robodyn.client import Client
from robodyn.contacts import (
    Contact,
    ContactDynamics,
    ContactInverseDynamics,
    ContactTrajectory,
    ImpulseDynamics,
)
from robodyn.equations import EntryStructure, Equations, EquationsStructure, Expressions
from robodyn.errors import (
    APIError,
    AssetNotFoundError,
    BadRequestError,
    CatalogRobotError,
    ConflictError,
    DeadlineExceededError,
    DimensionMismatchError,
    InfeasiblePathError,
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
    RobodynWarning,
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
    UnsupportedModelError,
    ValidationError,
)
from robodyn.identification import (
    Identification,
    IdentificationWarning,
    IdentifiedBody,
    InertialParameters,
    JointFriction,
)
from robodyn.model_check import LinkCheck, LinkGeometry, ModelCheck, ModelCheckFinding
from robodyn.models import Finding, FrameInfo, JointInfo, RobotInfo, RobotList, RobotSummary
from robodyn.outputs import ArrayType
from robodyn.payloads import CapacityMinimum, Payload, PayloadCapacity
from robodyn.progress import Progress, ProgressCallback
from robodyn.request_options import (
    Fill,
    InertiaCheck,
    Integrator,
    ReferenceFrame,
    RootJoint,
    Task,
)
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
from robodyn.trajectories import JointCheck, Retimed, TrajectoryCheck, Violation, Work
from robodyn.transport import DEFAULT_RETRY, DEFAULT_TIMEOUT, Retry

__all__ = [
    "DEFAULT_RETRY",
    "DEFAULT_TIMEOUT",
    "APIError",
    "ArrayType",
    "AssetNotFoundError",
    "AsyncClient",
    "AsyncStream",
    "BadRequestError",
    "BodyInertia",
    "CapacityMinimum",
    "CatalogRobotError",
    "CenterOfMass",
    "Centroidal",
    "Client",
    "ConflictError",
    "Contact",
    "ContactDynamics",
    "ContactInverseDynamics",
    "ContactTrajectory",
    "DeadlineExceededError",
    "DimensionMismatchError",
    "Energy",
    "EntryStructure",
    "Equations",
    "EquationsStructure",
    "Expressions",
    "Fill",
    "Finding",
    "ForwardDynamicsDerivatives",
    "FrameInfo",
    "FrameJacobian",
    "Identification",
    "IdentificationWarning",
    "IdentifiedBody",
    "ImpulseDynamics",
    "InertiaCheck",
    "InertialParameters",
    "Inertias",
    "InfeasiblePathError",
    "InputError",
    "Integrator",
    "InternalServerError",
    "InvalidConfigurationError",
    "InvalidModelError",
    "InverseDynamicsDerivatives",
    "JointCheck",
    "JointFriction",
    "JointInfo",
    "LinkCheck",
    "LinkGeometry",
    "MethodNotAllowedError",
    "ModelCheck",
    "ModelCheckFinding",
    "NonFiniteResultError",
    "NotFoundError",
    "NotReadyError",
    "OperationalSpace",
    "OverloadedError",
    "Payload",
    "PayloadCapacity",
    "PayloadTooLargeError",
    "Progress",
    "ProgressCallback",
    "ReferenceFrame",
    "ResponseFormatError",
    "Retimed",
    "Retry",
    "RobodynError",
    "RobodynWarning",
    "RobotInfo",
    "RobotList",
    "RobotNotFoundError",
    "RobotSummary",
    "RootJoint",
    "ServerError",
    "ServiceUnavailableError",
    "SingularConfigurationError",
    "Stream",
    "Task",
    "TimeoutError",
    "Trajectory",
    "TrajectoryCheck",
    "TransportError",
    "UnauthorizedError",
    "UnknownFrameError",
    "UnprocessableError",
    "UnsupportedMediaTypeError",
    "UnsupportedModelError",
    "ValidationError",
    "Violation",
    "Work",
    "__version__",
]
