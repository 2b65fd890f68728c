"""The client's shape: `Client` and `AsyncClient` have the same public methods, signatures and
docstrings, every docstring is written in the source (not attached at run time), every method
has one request builder with the same arguments, and no source file is too long."""

from __future__ import annotations

import ast
import inspect
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import robodyn
from robodyn._calls import BUILDERS, STREAMED

SOURCE = Path(robodyn.__file__).parent
IO = {"close", "aclose", "stream"}  # not requests: the connection pool and streams


def _public(cls: type) -> dict[str, Any]:
    return {
        name: getattr(cls, name)
        for name in dir(cls)
        if not name.startswith("_") and callable(getattr(cls, name))
    }


def _source_docstring(function: Any) -> str | None:
    tree = ast.parse(textwrap.dedent(inspect.getsource(function)))
    node = tree.body[0]
    assert isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef), function
    return ast.get_docstring(node)


def test_both_clients_have_the_same_methods_signatures_and_docstrings() -> None:
    sync, asynchronous = _public(robodyn.Client), _public(robodyn.AsyncClient)
    assert set(sync) - {"close"} == set(asynchronous) - {"aclose"}
    assert set(sync) - IO == set(BUILDERS)
    for name in set(sync) - IO:
        assert inspect.signature(sync[name]) == inspect.signature(asynchronous[name]), name
        assert inspect.iscoroutinefunction(asynchronous[name]), name
        assert not inspect.iscoroutinefunction(sync[name]), name
        assert sync[name].__doc__ == asynchronous[name].__doc__, name
    assert (
        inspect.signature(sync["stream"]).parameters
        == inspect.signature(asynchronous["stream"]).parameters
    )


def test_every_public_method_has_its_docstring_in_its_source() -> None:
    for cls in (robodyn.Client, robodyn.AsyncClient):
        for name, method in _public(cls).items():
            written = _source_docstring(method)
            assert written, f"{cls.__name__}.{name} has no docstring in its source"
            assert inspect.cleandoc(method.__doc__) == written, name  # not replaced at run time
    for name in STREAMED:  # the quantities: shapes and the payloads keyword are documented
        doc = robodyn.Client.__dict__.get(name) or getattr(robodyn.Client, name)
        assert "shape" in doc.__doc__ and "`payloads`" in doc.__doc__, name


def test_every_method_has_one_builder_with_its_arguments() -> None:
    for name, build in BUILDERS.items():
        method = inspect.signature(getattr(robodyn.Client, name)).parameters
        wanted = [p for n, p in method.items() if n not in ("self", "progress")]
        assert list(inspect.signature(build).parameters.values()) == wanted, name


def test_streams_offer_the_quantities_with_their_docstrings() -> None:
    assert "mass_matrix" in STREAMED and "contact_dynamics" in STREAMED
    assert not {"robot", "upload", "reduce", "delete", "inertias"} & set(STREAMED)
    for name in STREAMED:
        assert getattr(robodyn.Stream, name).__doc__ == getattr(robodyn.Client, name).__doc__


def test_no_source_file_is_over_400_lines() -> None:
    for path in SOURCE.rglob("*.py"):
        lines = len(path.read_text().splitlines())
        assert lines <= 400, f"{path.relative_to(SOURCE)} has {lines} lines"


def test_the_request_builder_chunks_batches_of_states_only() -> None:
    from robodyn._calls.request import array, request

    states = request("r", "gravity", array("gravity", 1), q=np.zeros((3000, 2)))
    assert states.chunks is not None and states.chunks.total == 3000
    path = request(
        "r", "retime", array("q", 2), independent_rows=False, waypoints=np.zeros((3000, 2))
    )
    assert path.chunks is None and path.route == "/v1/robots/{robot_id}/retime"
    assert path.json_body() == {"waypoints": np.zeros((3000, 2)).tolist()}
