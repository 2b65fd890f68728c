"""Pydantic's validation errors as a user reads them: one entry per mistake.

A field typed as a union (`q`: one state, a batch, or objects keyed by joint name) makes
pydantic report one error per member of the union, each under a location carrying the member's
internal name (`q.dict[constrained-str,union[float,list[float]]]`). For each union, this keeps
the member that matches the input best — the one whose type fits the value itself, then with
the fewest wrong types, then the one that got deepest into the value — or, when no member fits
the value at all, one entry saying what the field accepts ("an array of numbers, an array of
arrays of numbers or an object"). Locations read like the body: `q[2]`,
`external_forces[0].wrench`.

The work is bounded by what is reported, not by the body: pydantic's error objects are built
(`errors()`) only when there are at most `MAX_ERRORS_READ` of them (`error_count()` is free);
beyond, `pydantic_errors` re-validates a truncated view of the body (each object cut to its
first members plus the field names, each array to its first items) for a sample, and adds one
entry with the count. Every name echoed in a location is shortened to 64 characters.
"""

from __future__ import annotations

import itertools
import json
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel, ValidationError
from pydantic_core import from_json, to_json

from service.errors import did_you_mean

MAX_ERRORS_READ = 200
"""pydantic errors turned into objects at most; beyond, a sample of a truncated view."""
_VIEW_ITEMS = 20  # members (besides field names) and items kept per object and array
_NAME_CHARS = 64  # characters of a name shown at most in a location
TOO_MANY = "too_many_errors"
_PREFIX_BYTES = 64 * 1024
_CUT_OFF = frozenset(("missing", "too_short"))  # what a body's prefix lacks by being cut


def pydantic_errors(
    exc: ValidationError,
    model: type[BaseModel] | None = None,
    data: Callable[[], Any] | None = None,
    partial: bool = False,
) -> list[dict[str, Any]]:
    """pydantic's error objects of `exc` (loc, type, msg; no input, context or URL), at most
    about `MAX_ERRORS_READ`: with more, the errors of a truncated view of the body (`data()`,
    validated by `model`) and one last entry giving the count. `partial`: `data()` is only the
    beginning of the body (`json_prefix`), so members and items it cut off are not errors."""
    count = exc.error_count()
    if count <= MAX_ERRORS_READ:
        return [
            dict(e)
            for e in exc.errors(include_url=False, include_context=False, include_input=False)
        ]
    sample: list[dict[str, Any]] = []
    if model is not None and data is not None:
        try:
            model.model_validate(_truncated(data(), _field_names(model)))
        except ValidationError as again:
            if again.error_count() <= MAX_ERRORS_READ:
                sample = [
                    dict(e)
                    for e in again.errors(
                        include_url=False, include_context=False, include_input=False
                    )
                    if not (partial and e["type"] in _CUT_OFF)
                ]
        except Exception:
            sample = []
    return [
        *sample[:MAX_ERRORS_READ],
        {
            "loc": (),
            "type": TOO_MANY,
            "ctx": {"count": count},
            "msg": f"has {count} mistakes in all (the first are listed)",
        },
    ]


def json_prefix(body: bytes | bytearray | str) -> Any:
    """The decoded beginning (`_PREFIX_BYTES`) of a JSON body, what is cut off left out:
    constant work, for a sample of the errors of a body of any size. The beginning ends after
    a complete value (a number cut short would read as another number); NaN is refused as
    pydantic's JSON parser refuses it."""
    head = bytes(body[:_PREFIX_BYTES]) if not isinstance(body, str) else body[:_PREFIX_BYTES]
    if len(body) > _PREFIX_BYTES:
        if isinstance(head, str):
            end = max(head.rfind(","), head.rfind("]") + 1, head.rfind("}") + 1)
        else:
            end = max(head.rfind(b","), head.rfind(b"]") + 1, head.rfind(b"}") + 1)
        head = head[: max(end, 0)]
    return from_json(head, allow_partial=True, allow_inf_nan=False)


def prefix_errors(
    model: type[BaseModel], body: bytes | bytearray | str
) -> list[dict[str, Any]] | None:
    """The errors a truncated view of the beginning of a large JSON `body` (`json_prefix`)
    already shows for `model`, when none of them can come from the cut (a member or item
    missing, an array too short) or be counted short by it (unknown members): those of the
    whole body too (validation stops at the first wrong item of each array). Constant work,
    before pydantic validates all of the body (where a union-typed field such as `q` has a
    wrong value converted to Python once per form that refuses it: ~1 s for 5 MB of rows of
    strings). None when the view is valid or this is unsure."""
    try:  # as JSON again (a few kB): pydantic words some errors differently for JSON input
        model.model_validate_json(to_json(_truncated(json_prefix(body), _field_names(model))))
    except ValidationError as exc:
        if exc.error_count() > MAX_ERRORS_READ:
            return None
        errors = [
            dict(e)
            for e in exc.errors(include_url=False, include_context=False, include_input=False)
        ]
        uncertain = _CUT_OFF | {"extra_forbidden"}  # (unknown members are counted in all)
        return None if any(e["type"] in uncertain for e in errors) else errors
    except Exception:
        return None
    return None


def _field_names(model: type[BaseModel]) -> frozenset[str]:
    """The field names of `model` and of the models inside it (kept in a truncated view)."""
    names: set[str] = set()
    todo: list[Any] = [model]
    seen: set[Any] = set()
    while todo:
        cls = todo.pop()
        if cls in seen:
            continue
        seen.add(cls)
        for name, info in cls.model_fields.items():
            names.add(name)
            todo.extend(_models_in(info.annotation))
    return frozenset(names)


def _models_in(annotation: Any) -> list[Any]:
    out: list[Any] = []
    todo = [annotation]
    while todo and len(out) < 64:
        t = todo.pop()
        if isinstance(t, type) and issubclass(t, BaseModel):
            out.append(t)
        todo.extend(getattr(t, "__args__", ()) or ())
    return out


def _truncated(value: Any, keep: frozenset[str], depth: int = 0) -> Any:
    """`value` with every object cut to its first `_VIEW_ITEMS` members plus those named in
    `keep`, and every array to its first `_VIEW_ITEMS` items (work: what is kept)."""
    if depth > 32:
        return value
    if isinstance(value, dict):
        if len(value) <= _VIEW_ITEMS:
            items = list(value.items())
        else:
            first = list(itertools.islice(value.items(), _VIEW_ITEMS))
            kept = {k for k, _ in first}
            items = first + [(k, value[k]) for k in keep if k in value and k not in kept]
        return {k: _truncated(v, keep, depth + 1) for k, v in items}
    if isinstance(value, list):
        return [_truncated(v, keep, depth + 1) for v in value[:_VIEW_ITEMS]]
    return value


# pydantic's names of union members: types (`float`, `list[float]`, `constrained-str`,
# `function-after[...]`, ...) as opposed to field names, keys and indices.
_MEMBER = re.compile(
    r"^(float|int|str|bool|bytes|none|list|dict|set|tuple|union|literal|model|"
    r"nullable|tagged-union|lax-or-strict|json-or-python|is-instance|"
    r"constrained-\w+|function-\w+|JointState)(\[.*\])?$"
)
_KINDS = {
    "float": "a number",
    "int": "an integer",
    "str": "a string",
    "bool": "true or false",
    "none": "null",
    "list": "an array",
    "dict": "an object",
    "tuple": "an array",
}
_PLURALS = {
    "a number": "numbers",
    "an integer": "integers",
    "a string": "strings",
    "true or false": "booleans",
    "an object": "objects",
    "an array": "arrays",
}
_NOT_ITS_MEMBERS = ("missing", "extra_forbidden")
_REWORDED = {"extra_forbidden": "is not a field of this request"}


@dataclass(frozen=True)
class _Error:
    loc: tuple[Any, ...]
    type: str
    msg: str
    depth: int = 0  # how far below its union the error sits (set when a union is resolved)

    @property
    def wrong_type(self) -> bool:
        return self.type.endswith("_type") or self.type == "union_type"


def user_errors(
    raw: list[Any], schema: dict[str, Any] | None = None, schemas: dict[str, Any] | None = None
) -> list[dict[str, str]]:
    """`{"loc", "msg"}` entries, one per mistake, of pydantic's `errors()` list. With the
    request body's JSON `schema` (and the OpenAPI `schemas` its `$ref`s point into), an unknown
    member gets the close matches among the members allowed where it was sent."""
    errors = [_Error(tuple(e.get("loc", ())), str(e.get("type", "")), _message(e)) for e in raw]
    out = []
    for e in _resolve(errors):
        msg = e.msg
        if e.type == "extra_forbidden" and schema is not None and e.loc:
            where, name = _body_path(e.loc)[:-1], str(e.loc[-1])
            close = did_you_mean(name, _members(schema, schemas or {}, where))
            owners = _owners(schema, schemas or {}, where, name) if not close else []
            if owners:
                shown = " or ".join(f"`{o}`" for o, _ in owners[:3])
                owner, example = owners[0]
                close = f" (it is a member of {shown}: {{{json.dumps(owner)}: {example}}})"
            msg += close
        out.append({"loc": _location(e.loc), "msg": msg})
    return out


def _body_path(loc: tuple[Any, ...]) -> tuple[Any, ...]:
    return loc[1:] if loc[:1] == ("body",) else loc


def _members(schema: dict[str, Any], schemas: dict[str, Any], path: tuple[Any, ...]) -> list[str]:
    """The member names the object schema at `path` of `schema` allows ([] when unsure)."""
    nodes = [schema]
    for part in path:
        nodes = [
            child for node in _alternatives_of(nodes, schemas) for child in _children(node, part)
        ]
    return [
        name for node in _alternatives_of(nodes, schemas) for name in node.get("properties", {})
    ]


def _owners(
    schema: dict[str, Any], schemas: dict[str, Any], path: tuple[Any, ...], name: str
) -> list[tuple[str, str]]:
    """The members of the object at `path` whose own object (or array of objects) allows a
    member `name`: where a member sent one level too high belongs (`limits` of `retime`),
    each with the shape of its value (`{...}` or `[{...}]`)."""
    owners: list[tuple[str, str]] = []
    for member in _members(schema, schemas, path):
        if name in _members(schema, schemas, (*path, member)):
            owners.append((member, "{...}"))
        elif name in _members(schema, schemas, (*path, member, 0)):
            owners.append((member, "[{...}]"))
    return owners


def _alternatives_of(nodes: list[dict[str, Any]], schemas: dict[str, Any]) -> list[dict[str, Any]]:
    """`nodes` with `$ref`s resolved and `anyOf`/`oneOf`/`allOf` members flattened."""
    out: list[dict[str, Any]] = []
    todo = list(nodes)
    while todo and len(out) < 64:
        node = todo.pop(0)
        ref = node.get("$ref")
        if isinstance(ref, str):
            todo.append(schemas.get(ref.rsplit("/", 1)[-1], {}))
            continue
        members = [m for key in ("anyOf", "oneOf", "allOf") for m in node.get(key, [])]
        todo.extend(members)
        if not members:
            out.append(node)
    return out


def _children(node: dict[str, Any], part: Any) -> list[dict[str, Any]]:
    if isinstance(part, int) and isinstance(node.get("items"), dict):
        return [node["items"]]
    if isinstance(part, str) and part in node.get("properties", {}):
        return [node["properties"][part]]
    return []


def _message(error: dict[str, Any]) -> str:
    kind = str(error.get("type", ""))
    msg = _REWORDED.get(kind, str(error.get("msg", "invalid")))
    if kind == "value_error":
        msg = msg.removeprefix("Value error, ")
    msg = msg.replace(" after validation", "")
    return re.sub(r"^(Input|Value|List|String|Object) should ", "must ", msg)


def _is_member(part: Any) -> bool:
    return isinstance(part, str) and bool(_MEMBER.match(part))


def _resolve(errors: list[_Error]) -> list[_Error]:
    """`errors` with every union's members reduced to the best one (innermost unions first)."""
    out: list[_Error] = []
    unions: dict[tuple[Any, ...], dict[str, list[_Error]]] = {}
    for e in errors:
        at = next((i for i, part in enumerate(e.loc) if _is_member(part)), None)
        if at is None:
            out.append(e)
            continue
        member = unions.setdefault(e.loc[:at], {}).setdefault(e.loc[at], [])
        member.append(_Error(e.loc[:at] + e.loc[at + 1 :], e.type, e.msg))
    for prefix, members in unions.items():
        resolved = {name: _resolve(errs) for name, errs in members.items()}
        out.extend(_best(prefix, resolved))
    return out


def _best(prefix: tuple[Any, ...], members: dict[str, list[_Error]]) -> list[_Error]:
    """The errors of the member matching best, or one error listing what the field takes."""

    def misfit(errs: list[_Error]) -> bool:  # the value itself is not of the member's type
        return any(
            (e.wrong_type and len(e.loc) == len(prefix))  # (nor an object lacking a
            or (e.type == "missing" and len(e.loc) == len(prefix) + 1)  # model's field)
            for e in errs
        )

    fitting = {name: errs for name, errs in members.items() if not misfit(errs)}
    if not fitting:
        accepted = _alternatives([_describe(name) for name in members])
        return [_Error(prefix, "union_type", f"must be {accepted}")]
    best = min(
        fitting.values(),
        key=lambda errs: (  # a member missing, or not having, a
            sum(
                e.wrong_type or e.type in _NOT_ITS_MEMBERS for e in errs
            ),  # model's field fits less
            -max(len(e.loc) for e in errs),
            len(errs),
        ),
    )
    return best


def _describe(member: str) -> str:
    """A union member's type in words: `list[list[float]]` → "an array of arrays of numbers"."""
    name, _, inner = member.partition("[")
    inner = inner[:-1] if inner.endswith("]") else inner
    if name.startswith("constrained-"):
        return _KINDS.get(name.removeprefix("constrained-"), "a value")
    if name in ("list", "set", "tuple"):
        one_type = inner and "," not in _top_level(inner)
        return f"an array of {_plural(_describe(inner))}" if one_type else "an array"
    return _KINDS.get(name, "an object" if name[:1].isupper() else "a value")


def _top_level(text: str) -> str:
    """`text` without anything inside brackets (to find its top-level commas)."""
    depth, kept = 0, []
    for ch in text:
        depth += ch == "["
        if depth == 0:
            kept.append(ch)
        depth -= ch == "]"
    return "".join(kept)


def _plural(description: str) -> str:
    if description in _PLURALS:
        return _PLURALS[description]
    if description.startswith("an array"):
        return "arrays" + description.removeprefix("an array")
    return "values"


def _alternatives(items: list[str]) -> str:
    unique = list(dict.fromkeys(items))
    return unique[0] if len(unique) == 1 else f"{', '.join(unique[:-1])} or {unique[-1]}"


def _location(loc: tuple[Any, ...]) -> str:
    """`('body', 'external_forces', 0, 'wrench')` → `external_forces[0].wrench`; names longer
    than 64 characters shortened."""
    out = ""
    for part in loc:
        if isinstance(part, str) and len(part) > _NAME_CHARS:
            part = part[:_NAME_CHARS] + "…"
        if part == "body" and not out:
            continue
        if isinstance(part, int) or (isinstance(part, str) and part.isdigit()):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return out or "body"
