"""Pydantic's validation errors as a user reads them: one entry per mistake.

A field typed as a union (`q`: one state, a batch, or objects keyed by joint name) makes
pydantic report one error per member of the union, each under a location carrying the member's
internal name (`q.dict[constrained-str,union[float,list[float]]]`). For each union, this keeps
the member that matches the input best — the one whose type fits the value itself, then with
the fewest wrong types, then the one that got deepest into the value — or, when no member fits
the value at all, one entry saying what the field accepts ("an array of numbers, an array of
arrays of numbers or an object"). Locations read like the body: `q[2]`,
`external_forces[0].wrench`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from service.errors import did_you_mean

# pydantic's names of union members: types (`float`, `list[float]`, `constrained-str`,
# `function-after[...]`, ...) as opposed to field names, keys and indices.
_MEMBER = re.compile(r"^(float|int|str|bool|bytes|none|list|dict|set|tuple|union|literal|model|"
                     r"nullable|tagged-union|lax-or-strict|json-or-python|is-instance|"
                     r"constrained-\w+|function-\w+)(\[.*\])?$")
_KINDS = {"float": "a number", "int": "an integer", "str": "a string", "bool": "true or false",
          "none": "null", "list": "an array", "dict": "an object", "tuple": "an array"}
_PLURALS = {"a number": "numbers", "an integer": "integers", "a string": "strings",
            "true or false": "booleans", "an object": "objects", "an array": "arrays"}
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


def user_errors(raw: list[Any], schema: dict[str, Any] | None = None,
                schemas: dict[str, Any] | None = None) -> list[dict[str, str]]:
    """`{"loc", "msg"}` entries, one per mistake, of pydantic's `errors()` list. With the
    request body's JSON `schema` (and the OpenAPI `schemas` its `$ref`s point into), an unknown
    member gets the close matches among the members allowed where it was sent."""
    errors = [_Error(tuple(e.get("loc", ())), str(e.get("type", "")), _message(e)) for e in raw]
    out = []
    for e in _resolve(errors):
        msg = e.msg
        if e.type == "extra_forbidden" and schema is not None and e.loc:
            allowed = _members(schema, schemas or {}, _body_path(e.loc)[:-1])
            msg += did_you_mean(str(e.loc[-1]), allowed)
        out.append({"loc": _location(e.loc), "msg": msg})
    return out


def _body_path(loc: tuple[Any, ...]) -> tuple[Any, ...]:
    return loc[1:] if loc[:1] == ("body",) else loc


def _members(schema: dict[str, Any], schemas: dict[str, Any], path: tuple[Any, ...]
             ) -> list[str]:
    """The member names the object schema at `path` of `schema` allows ([] when unsure)."""
    nodes = [schema]
    for part in path:
        nodes = [child for node in _alternatives_of(nodes, schemas)
                 for child in _children(node, part)]
    return [name for node in _alternatives_of(nodes, schemas)
            for name in node.get("properties", {})]


def _alternatives_of(nodes: list[dict[str, Any]], schemas: dict[str, Any]
                     ) -> list[dict[str, Any]]:
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
        member.append(_Error(e.loc[:at] + e.loc[at + 1:], e.type, e.msg))
    for prefix, members in unions.items():
        resolved = {name: _resolve(errs) for name, errs in members.items()}
        out.extend(_best(prefix, resolved))
    return out


def _best(prefix: tuple[Any, ...], members: dict[str, list[_Error]]) -> list[_Error]:
    """The errors of the member matching best, or one error listing what the field takes."""
    def misfit(errs: list[_Error]) -> bool:  # the value itself is not of the member's type
        return any(e.wrong_type and len(e.loc) == len(prefix) for e in errs)

    fitting = {name: errs for name, errs in members.items() if not misfit(errs)}
    if not fitting:
        accepted = _alternatives([_describe(name) for name in members])
        return [_Error(prefix, "union_type", f"must be {accepted}")]
    best = min(fitting.values(), key=lambda errs: (
        sum(e.wrong_type for e in errs), -max(len(e.loc) for e in errs), len(errs)))
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
    """`('body', 'external_forces', 0, 'wrench')` → `external_forces[0].wrench`."""
    out = ""
    for part in loc:
        if part == "body" and not out:
            continue
        if isinstance(part, int) or (isinstance(part, str) and part.isdigit()):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return out or "body"
