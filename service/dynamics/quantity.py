"""What a dynamics quantity is, for the layers above: the one declaration of each quantity.

A `Quantity` says everything the service needs to know about one quantity: its name (the route
is `POST /v1/robots/{id}/<name>`), its joint-space inputs, the function computing it, its batch
form, the size of its answer, the cost of computing it and which answers are joint-space
vectors. The routes, the OpenAPI document, the answer budget and the stream are derived from
it (`service.api.quantities` adds the request and answer schemas; nothing else names it).

A quantity's `compute(robot, states, **options)` takes validated joint-space `States` (arrays
of shape (N, n), see `service.states`) and keyword options (e.g. `frame`), and returns named
arrays whose first axis is the batch axis N. `parallel(robot, states, should_stop)`, where given,
computes the same arrays bit for bit, faster for large N (Pinocchio's OpenMP batch algorithms),
asking `should_stop` (or nothing, when None) between its native calls.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from dataclasses import KW_ONLY, dataclass
from typing import Any, Protocol

import numpy as np

from service.dynamics import answer_arrays
from service.dynamics.stopping import ShouldStop, hand_over, report_progress
from service.errors import ComputationStopped, NonFiniteResult, SingularConfiguration
from service.registry.robot import Robot
from service.state_numbers import all_finite
from service.states import States

Results = dict[str, np.ndarray]
Compute = Callable[..., Results]
Work = Callable[[Robot, States, dict[str, Any]], int]
AnswerSize = Callable[[Robot, dict[str, Any], bool], int]
"""(robot, options, v given) -> how many numbers the answer of one state holds."""
SmallerRequest = Callable[[Robot, int], str]
"""(robot, numbers that fit) -> what to ask for when even one state's answer is too large."""
Fill = Callable[[Robot, States, Results], None]
"""(robot, states, out) -> None: each state's answer written into row i of each array of out."""


class Split(Protocol):
    """`split(robot, quantity, states, out)` fills `out` as `quantity.state_by_state.fill`
    would, its states shared between `processes` processes (this one and helpers that write
    their slices into `out`'s memory: `service.api.workers.batch_split`); given to `run`."""

    processes: int

    def __call__(self, robot: Robot, quantity: Quantity, s: States, out: Results) -> None: ...


@dataclass(frozen=True)
class StateByState:
    """A quantity computed state by state into given arrays, so that a batch may be split
    between processes that each write their slice of the answer.

    `shapes(robot)` gives each answer's shape for one state; `fill(robot, s, out)` writes the
    answer of state i of `s` into `out[name][i]` (arrays of shape (N, *shapes[name])); the same
    algorithm per state whoever runs it, so a split batch is bit for bit the serial one.
    `answer` names the quantity in the finiteness check."""

    shapes: Callable[[Robot], dict[str, tuple[int, ...]]]
    fill: Fill
    answer: str

    def empty(self, robot: Robot, n: int) -> Results:
        """Uninitialised answer arrays for n states (`answer_arrays.empty`: new memory, or the
        request's)."""
        return answer_arrays.empty(
            {name: (n, *shape) for name, shape in self.shapes(robot).items()}
        )

    def compute(self, robot: Robot, s: States) -> Results:
        """The serial batch: every state filled in this process, checked finite."""
        out = self.empty(robot, s.count)
        self.fill(robot, s, out)
        return finite(self.answer, **out)


@dataclass(frozen=True)
class Quantity:
    """A dynamics quantity, served as `POST /v1/robots/{id}/<name>`.

    `inputs` are the required joint-space arrays and `optional` the optional ones (names from
    `service.states.SPACES`: q, v, a, tau, waypoints); every other request field is passed to
    `compute` as a keyword option. `settings` names service settings (`service.settings.Settings`
    fields, e.g. limits) that are passed to `compute` as keyword options too.
    `answer_size(robot, options, with_v)` counts the numbers of one state's answer exactly as
    `compute` shapes it (from the robot's dimensions and the options alone, never the values:
    the answer budget refuses an answer too large before computing it);
    `smaller_request(robot, n)` says what to ask for instead when not even one state's answer
    fits in n numbers.
    `joint_answers` names the answers that are joint-space vectors (last axis nq for an answer
    named "q", else nv), given keyed by joint name on request (`"joint_names": true`), and
    `named_options` the options that may be given keyed by joint name (a dotted path into the
    option, "nq" or "nv") pairs, turned into arrays by the request layer before `compute` runs.
    `work(robot, states, options)` estimates the cost in state×dof units (default: states ×
    nv); larger work than the inline limit is computed off the event loop. A `compute` that
    takes `should_stop` (`stoppable`) asks it between its steps or states; any other batch is
    stopped between chunks by `run`.
    """

    name: str
    inputs: tuple[str, ...]
    compute: Compute
    summary: str
    _: KW_ONLY
    answer_size: AnswerSize
    optional: tuple[str, ...] = ()
    parallel: Compute | None = None
    parallel_from: int = 64  # smallest batch for which `parallel` is used
    joint_answers: tuple[str, ...] = ()
    named_options: tuple[tuple[str, str], ...] = ()
    settings: tuple[str, ...] = ()
    work: Work | None = None
    smaller_request: SmallerRequest | None = None
    whole_batch: bool = False
    """True: the batch's answer is more than its states' answers side by side (e.g. a minimum
    over the states), so it is never computed in chunks (`run`)."""
    tensor_options: tuple[str, ...] = ()
    """Options of one number per sample (e.g. trajectory-check's `t`) that the binary form may
    carry as 1-D tensors rather than in its JSON header."""
    state_by_state: StateByState | None = None
    """Given when `compute` (without options) is `state_by_state.compute`: a batch that `run`
    may split between processes (its `split`)."""
    finite_in_answer: tuple[str, ...] = ()
    """Inputs (never q) of which a NaN or ±inf always makes the answer of `parallel` non-finite:
    RNEA reads v and a only in sums and products (no division, comparison or function of
    them), where NaN stays NaN and ±inf gives ±inf, or NaN once multiplied by 0 (tested for
    each velocity coordinate of every catalog robot). A large batch leaves their finiteness
    to the answer's check (`finite_from_answer`)."""

    @functools.cached_property
    def stoppable(self) -> bool:
        """Whether `compute` takes `should_stop` (asked between its steps or states)."""
        return "should_stop" in inspect.signature(self.compute).parameters


@functools.cache
def _strictly_lower(n: int) -> np.ndarray:
    """The boolean mask of the entries below the diagonal of an n×n matrix (read-only)."""
    mask = np.tril(np.ones((n, n), dtype=bool), -1)
    mask.flags.writeable = False
    return mask


def mirror_upper(out: np.ndarray) -> np.ndarray:
    """Make every n×n matrix of `out` (shape (..., n, n)) symmetric from its upper triangle,
    in place, and return it. Pinocchio's algorithms for M⁻¹ and the derivatives (∂τ/∂a = M,
    ∂a/∂τ = M⁻¹) guarantee only that triangle. (Its Python `crba` returns M symmetric.)"""
    np.copyto(out, np.swapaxes(out, -1, -2), where=_strictly_lower(out.shape[-1]))
    return out


def matrix(value: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """A matrix result of Pinocchio as a (rows, cols) array, whatever shape the binding gave.

    Pinocchio's Python bindings (eigenpy) hand back a dynamic-size matrix with one column as a
    1-D array: J of a 1-dof robot comes back (6,), not (6, 1). Every matrix result passes
    through here, so its shape comes from the model (nv) and the task, never from the binding.
    A 2-D result is Eigen's rows × cols already and is returned as it is (about 0.1 µs: this
    is on the hot path); a 1-D one is reshaped (a view, no copy)."""
    return value if value.ndim == 2 else value.reshape(rows, cols)


def finite(quantity: str, **results: np.ndarray) -> Results:
    """Return `results`, or raise NonFiniteResult naming the first non-finite one."""
    for name, value in results.items():
        if not all_finite(value):
            raise NonFiniteResult(
                f"{quantity}: the computed {name} is not finite for these "
                "inputs (is a moving body massless, or an input extreme?)"
            )
    return results


def has_parallel_form(quantity: Quantity, options: dict[str, Any]) -> bool:
    """Whether a batch of `quantity` with `options` (of `parallel_from` states or more) is
    computed by its parallel algorithm (`service.dynamics.parallel`) in the OpenMP master
    thread."""
    return quantity.parallel is not None and not options


def finite_from_answer(quantity: Quantity, options: dict[str, Any]) -> frozenset[str]:
    """The inputs whose finiteness a batch of `quantity` with `options` may leave to its
    answer's check (`Quantity.finite_in_answer`, for its parallel form): when the answer is
    not finite, the caller checks the inputs as usual, so the error is the one the inputs
    give (saves reading them once, 0.3–0.5 ms for 10,000 Talos states)."""
    return (
        frozenset(quantity.finite_in_answer)
        if has_parallel_form(quantity, options)
        else frozenset()
    )


def run(
    robot: Robot,
    quantity: Quantity,
    s: States,
    options: dict[str, Any],
    should_stop: ShouldStop | None = None,
    split: Split | None = None,
) -> dict[str, Any]:
    """Compute one quantity and drop the batch axis again for a single-state request.

    Every computation runs inside the one guard of numerical linear algebra: a factorization
    or eigen-decomposition that fails (numpy's `LinAlgError`: no convergence, a singular
    matrix, values beyond float64) is `SingularConfiguration` (422), never a 500.

    `should_stop` (optional, `service.dynamics.stopping`) makes the computation stoppable: a
    quantity whose function takes `should_stop` (simulate, the contact quantities) asks it
    between steps or states, and so does a `parallel` batch between its native calls
    (`service.dynamics.parallel`); any other batch is computed in chunks of about CHUNK_WORK
    states × nv, and `should_stop` is asked before each.

    `split` (optional) computes a batch of a `state_by_state` quantity without options, its
    states shared between this process and helper processes that write their slices into the
    same answer arrays; it decides itself whether the batch is large enough to pay. Its chunks
    are `split.processes` times larger (every process computes about one chunk's work)."""
    by_state = quantity.state_by_state
    split_batch = split is not None and by_state is not None and not options
    parallel_batch = (
        has_parallel_form(quantity, options)
        and s.count >= quantity.parallel_from
        and not split_batch
    )
    if should_stop is not None:
        if quantity.stoppable:
            options = {**options, "should_stop": should_stop}
        elif parallel_batch:
            pass  # asks `should_stop` between its own chunks (`service.dynamics.parallel`)
        elif (
            s.count > _chunk_states(robot, quantity, split)
            and not quantity.whole_batch
            and not _per_state_options(options)
        ):
            return _run_in_chunks(robot, quantity, s, options, should_stop, split)
        elif should_stop():  # computed whole: stopped only before it starts
            raise ComputationStopped(f"{quantity.name}: stopped before computing")
    try:
        if split_batch:
            assert split is not None and by_state is not None  # (split_batch says so)
            out = by_state.empty(robot, s.count)
            split(robot, quantity, s, out)
            results = finite(by_state.answer, **out)
        elif parallel_batch:
            assert quantity.parallel is not None  # (parallel_batch says so)
            results = finite(quantity.name, **quantity.parallel(robot, s, should_stop))
        else:
            results = quantity.compute(robot, s, **options)
    except np.linalg.LinAlgError as exc:
        raise linear_algebra_failure(quantity.name, exc) from None
    if robot.q_to_api is not None and "q" in quantity.joint_answers:
        results["q"] = robot.api_q(results["q"])  # configurations answered (simulate's)
    # (a non-array answer, e.g. the frame names of frame-placements, is given once as it is)
    return {
        name: s.unbatch(value) if isinstance(value, np.ndarray) else value
        for name, value in results.items()
    }


CHUNK_WORK = 50_000
"""States × nv of one chunk of a stoppable batch: a few to a few tens of milliseconds."""


def _per_state_options(options: dict[str, Any]) -> bool:
    """Whether an option has one row per state (external wrenches given per state): such a
    batch is computed whole, its options are not split."""
    return any(np.ndim(force.get("wrench")) == 2 for force in options.get("external_forces") or ())


def _chunk_states(robot: Robot, quantity: Quantity, split: Split | None = None) -> int:
    size = max(quantity.parallel_from, CHUNK_WORK // max(robot.nv, 1))
    if split is not None and quantity.state_by_state is not None:
        size *= max(1, split.processes)  # each process computes about one chunk's work
    return size


def _run_in_chunks(
    robot: Robot,
    quantity: Quantity,
    s: States,
    options: dict[str, Any],
    should_stop: ShouldStop,
    split: Split | None = None,
) -> dict[str, Any]:
    """`run` over consecutive chunks of the batch, asking `should_stop` before each; the
    answers are written into arrays of the whole batch (non-array answers, e.g. frame names,
    come from the first chunk). A true `should_stop` raises `ComputationStopped`."""
    n, size = s.count, _chunk_states(robot, quantity, split)
    out: dict[str, Any] = {}
    for start in range(0, n, size):
        hand_over()
        if should_stop():
            raise ComputationStopped(
                f"{quantity.name}: stopped at state {start} of {n} "
                "(the client went away or the request's deadline "
                "passed)"
            )
        report_progress(should_stop, start, n, "state")
        part = States(
            {name: a[start : start + size] for name, a in s.arrays.items()}, True, first=start
        )
        for name, value in run(robot, quantity, part, options, split=split).items():
            if not isinstance(value, np.ndarray):
                out.setdefault(name, value)
                continue
            if name not in out:
                out[name] = np.empty((n, *value.shape[1:]), dtype=value.dtype)
            out[name][start : start + value.shape[0]] = value
    return out


def linear_algebra_failure(quantity: str, exc: np.linalg.LinAlgError) -> SingularConfiguration:
    """The 422 answer to a failed solve: the numbers of these inputs are beyond what the
    linear algebra of `quantity` can factorize (numpy's message names the failure)."""
    reason = str(exc).split("\n", 1)[0][:120] or "the solver failed"
    return SingularConfiguration(
        f"{quantity}: the linear algebra failed for these inputs ({reason}): the "
        "configuration is singular for it or an input is too extreme to compute with"
    )


def nv_numbers(robot: Robot, options: dict[str, Any], with_v: bool) -> int:
    """The answer size of one joint-space vector (nv numbers), e.g. τ."""
    return robot.nv


def nv_squared_numbers(robot: Robot, options: dict[str, Any], with_v: bool) -> int:
    """The answer size of one nv×nv matrix, e.g. M."""
    return robot.nv * robot.nv
