"""What the sweep (tests/service/api/test_sweep.py) sends: the robots, the routes and the bodies.

Routes are read from the app (every POST route under /v1/robots/{robot_id}/), and each route's
request fields from its OpenAPI request schema, so an endpoint added later is swept without
touching this file: fields this module does not know get values from their JSON schema.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

PREFIX = "/v1/robots/{robot_id}/"
INERTIAL = (
    '<inertial><origin xyz="0.1 0.05 -0.2"/><mass value="1.5"/><inertia ixx="0.1" '
    'ixy="0" ixz="0" iyy="0.12" iyz="0" izz="0.08"/></inertial>'
)
LIMIT = '<limit lower="-2" upper="2" effort="10" velocity="5"/>'


def _one_joint(kind: str, link: str = "arm", joint: str = "j", name: str = "one") -> str:
    return (
        f'<robot name="{name}"><link name="base"/><link name="{link}">{INERTIAL}</link>'
        f'<joint name="{joint}" type="{kind}"><parent link="base"/><child link="{link}"/>'
        f'<axis xyz="0.3 0.4 0.5"/>{LIMIT}</joint></robot>'
    )


def _mjcf(joint: str) -> str:
    return (
        '<mujoco model="m"><worldbody><body name="b" pos="0 0 1">'
        f'{joint}<inertial pos="0 0 -0.3" mass="2" diaginertia="0.1 0.2 0.3"/>'
        '<site name="tip" pos="0 0 -0.5"/></body></worldbody></mujoco>'
    )


LONG = "n" * 256
ODD_UPLOADS: dict[str, dict[str, Any]] = {
    **{
        f"one-{kind}": {"urdf": _one_joint(kind)}
        for kind in ("revolute", "continuous", "prismatic", "floating", "planar")
    },
    "one-link-free-flyer": {
        "urdf": f'<robot name="box"><link name="box">{INERTIAL}</link></robot>',
        "root_joint": "free-flyer",
    },
    "one-link-planar-root": {
        "urdf": f'<robot name="box"><link name="box">{INERTIAL}</link></robot>',
        "root_joint": "planar",
    },
    "fixed-only": {"urdf": _one_joint("fixed")},
    "same-name-link-joint": {"urdf": _one_joint("revolute", link="arm", joint="arm")},
    "long-names": {"urdf": _one_joint("revolute", link=LONG, joint=LONG[:-1] + "j", name=LONG)},
    "pendulum-free-flyer-root": {"urdf": _one_joint("revolute"), "root_joint": "free-flyer"},
    **{
        f"mjcf-{kind}": {"mjcf": _mjcf(joint)}
        for kind, joint in {
            "hinge": '<joint name="h" type="hinge" axis="0 1 0"/>',
            "slide": '<joint name="s" type="slide" axis="0 0 1"/>',
            "ball": '<joint name="b" type="ball"/>',
            "free": '<freejoint name="f"/>',
        }.items()
    },
}


def post_routes(app: Any) -> list[str]:
    """Every POST route under /v1/robots/{robot_id}/ of the app: its own routes (the lean
    dynamics routes) and those of its routers (as the OpenAPI document lists them)."""
    out = [
        route.path
        for route in app.routes
        if "POST" in (getattr(route, "methods", None) or ())
        and getattr(route, "path", "").startswith(PREFIX)
    ]
    out += [
        path
        for path, methods in app.openapi()["paths"].items()
        if "post" in methods and path.startswith(PREFIX)
    ]
    return list(dict.fromkeys(out))


def request_fields(openapi: dict[str, Any], path: str) -> tuple[dict[str, Any], set[str]]:
    """(properties, required names) of the JSON request schema of POST `path`."""
    body = openapi["paths"][path]["post"].get("requestBody", {})
    schema = body.get("content", {}).get("application/json", {}).get("schema", {})
    schema = _resolve(openapi, schema)
    return schema.get("properties", {}), set(schema.get("required", ()))


def _resolve(openapi: dict[str, Any], schema: dict[str, Any]) -> dict[str, Any]:
    while "$ref" in schema:
        schema = openapi["components"]["schemas"][schema["$ref"].rsplit("/", 1)[-1]]
    return schema


def random_configuration(info: dict[str, Any], rng: np.random.Generator) -> list[float]:
    """A valid q from the robot's description (GET /v1/robots/{id})."""
    q = list(info["neutral_configuration"])
    for joint in info["joints"]:
        i, kind = joint["idx_q"], joint["type"]
        if kind in ("revolute", "prismatic"):
            lo = max(joint["lower"][0] if joint["lower"][0] is not None else -1.0, -math.pi)
            hi = min(joint["upper"][0] if joint["upper"][0] is not None else 1.0, math.pi)
            q[i] = float(rng.uniform(lo, hi)) if hi > lo else q[i]
        elif kind in ("continuous", "planar"):
            t = rng.uniform(-math.pi, math.pi)
            q[i + joint["nq"] - 2 : i + joint["nq"]] = [math.cos(t), math.sin(t)]
        elif kind in ("free_flyer", "spherical"):
            quat = rng.normal(size=4)
            q[i + joint["nq"] - 4 : i + joint["nq"]] = list(quat / np.linalg.norm(quat))
    return q


class Bodies:
    """Valid and hostile request bodies for one robot."""

    def __init__(self, info: dict[str, Any], openapi: dict[str, Any]) -> None:
        self.info, self.openapi = info, openapi
        self.nv = info["nv"]
        self.frames = [f["name"] for f in info["frames"]]
        self.joints = [j["name"] for j in info["joints"]]

    def _value(
        self, name: str, schema: dict[str, Any], rng: np.random.Generator, batch: int | None
    ) -> Any:
        def states(make: Callable[[], list[float]]) -> Any:
            return make() if batch is None else [make() for _ in range(batch)]

        if name == "q":
            return states(lambda: random_configuration(self.info, rng))
        if name in ("v", "a", "tau"):
            return states(lambda: rng.normal(size=self.nv).tolist())
        if name == "frame":
            return str(rng.choice(self.frames))
        if name == "damping":
            return float(rng.choice([0.0, 0.01, 1.0]))
        if name == "dt":
            return 0.005
        if name == "steps":
            return int(rng.integers(1, 4))
        if name == "external_forces":
            return [{"frame": str(rng.choice(self.frames)), "wrench": rng.normal(size=6).tolist()}]
        if name == "locked_joints":
            if not self.joints:
                return {"no-joint": [0.0]}
            joint = self.info["joints"][int(rng.integers(len(self.joints)))]
            return {
                joint["name"]: self.info["neutral_configuration"][
                    joint["idx_q"] : joint["idx_q"] + joint["nq"]
                ]
            }
        if name in ("controller", "name"):
            return None
        return _from_schema(_resolve(self.openapi, schema), rng)

    def valid(self, path: str, rng: np.random.Generator) -> dict[str, Any]:
        """A valid body for `path`: required fields always, optional ones at random."""
        properties, required = request_fields(self.openapi, path)
        batch = int(rng.integers(1, 4)) if rng.random() < 0.3 else None
        body = {}
        for name, schema in properties.items():
            if name in required or (name not in ("joint_names",) and rng.random() < 0.5):
                value = self._value(name, schema, rng, batch)
                if value is not None:
                    body[name] = value
        return body


def _from_schema(schema: dict[str, Any], rng: np.random.Generator) -> Any:
    """A value of a JSON schema (for fields this module does not know)."""
    if "enum" in schema:
        return rng.choice(schema["enum"]).item()
    if "anyOf" in schema:
        return _from_schema(schema["anyOf"][0], rng)
    kind = schema.get("type")
    if kind == "number":
        return float(rng.normal())
    if kind == "integer":
        return 1
    if kind == "boolean":
        return bool(rng.random() < 0.5)
    if kind == "string":
        return "x"
    if kind == "array":
        return [
            _from_schema(schema.get("items", {}), rng) for _ in range(schema.get("minItems", 0))
        ]
    return None


Request = tuple[str, bytes, dict[str, str]]  # (label, content, headers)
JSON = {"Content-Type": "application/json"}


def _json(label: str, body: Any) -> Request:
    return label, json.dumps(body, allow_nan=True).encode(), JSON


def _numbers_replaced(value: Any, number: float) -> Any:
    if isinstance(value, list):
        return [_numbers_replaced(x, number) for x in value]
    if isinstance(value, dict):
        return {k: _numbers_replaced(x, number) for k, x in value.items()}
    return number if isinstance(value, float) else value


BINARY = {"Content-Type": "application/vnd.robodyn.binary"}


def binary_body(fields: dict[str, Any], arrays: dict[str, np.ndarray]) -> bytes:
    """A body in the binary form (docs/binary-format.md), written here from the format."""
    descriptors, chunks, offset = {}, [], 0
    for name, value in arrays.items():
        data = np.ascontiguousarray(value, dtype="<f8")
        descriptors[name] = {"shape": list(data.shape), "offset": offset}
        chunks.append(data.tobytes())
        offset += data.nbytes
    header = json.dumps({"fields": fields, "arrays": descriptors}, allow_nan=True).encode()
    pad = b"\0" * ((8 - (8 + len(header)) % 8) % 8)
    return b"RDY1" + len(header).to_bytes(4, "little") + header + pad + b"".join(chunks)


def _binary_variants(body: dict[str, Any]) -> Iterator[Request]:
    """The body in the binary form (numeric arrays as arrays), and broken binary bodies."""
    arrays: dict[str, np.ndarray] = {}
    fields: dict[str, Any] = {}
    for name, value in body.items():
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            array = None
        if array is not None and array.ndim in (1, 2) and array.size and isinstance(value, list):
            arrays[name] = array
        else:
            fields[name] = value
    if not arrays:
        return
    yield "binary-valid", binary_body(fields, arrays), BINARY
    first = next(iter(arrays))
    for label, replaced in (
        ("nan", np.full_like(arrays[first], np.nan)),
        ("3d", arrays[first][np.newaxis, np.newaxis]),
        ("empty-rows", np.zeros((0, arrays[first].shape[-1]))),
        ("scalar", np.zeros(())),
        ("wide", np.zeros((1, 10_000))),
    ):
        yield (f"binary-{first}-{label}", binary_body(fields, {**arrays, first: replaced}), BINARY)
    yield "binary-unknown-array", binary_body(fields, {**arrays, "zzz": np.zeros(3)}), BINARY
    yield "binary-missing-array", binary_body(fields, {}), BINARY


def hostile(body: dict[str, Any]) -> Iterator[Request]:
    """Broken variants of a valid body: every way a client can get it wrong."""
    for number, label in (
        (math.nan, "nan"),
        (math.inf, "inf"),
        (-math.inf, "-inf"),
        (1e308, "huge"),
        (-1e200, "-huge"),
        (1e-320, "denormal"),
    ):
        yield _json(f"all-numbers-{label}", _numbers_replaced(body, number))
    for name, value in body.items():
        for label, bad in (
            ("null", None),
            ("string", "abc"),
            ("bool", True),
            ("int", 7),
            ("object", {"zz": 1}),
            ("empty-list", []),
            ("empty-object", {}),
            ("list-of-strings", ["a", "b"]),
            ("deep", [[[1.0]]]),
            ("huge-number", 1e200),
            ("negative", -1.0),
            ("zero", 0),
            ("huge-int", 10**30),
            ("long-string", "s" * 5000),
        ):
            yield _json(f"{name}-{label}", {**body, name: bad})
        if isinstance(value, list) and value:
            yield _json(f"{name}-one-more", {**body, name: [*value, value[-1]]})
            yield _json(f"{name}-one-less", {**body, name: value[:-1]})
            if isinstance(value[0], list):
                ragged = [value[0], value[0][:-1] or [1.0], value[0]]
                yield _json(f"{name}-ragged", {**body, name: ragged})
                yield _json(f"{name}-empty-batch", {**body, name: []})
                yield _json(f"{name}-batch-of-empties", {**body, name: [[] for _ in value]})
            else:
                yield _json(f"{name}-as-batch-of-one", {**body, name: [value]})
                yield _json(f"{name}-ragged-schedule", {**body, name: [value, value[:-1]]})
        yield _json(f"without-{name}", {k: x for k, x in body.items() if k != name})
    yield _json("unknown-field", {**body, "zzz": 1})
    yield _json("damping-1e200", {**body, "damping": 1e200})
    yield _json("frame-unknown", {**body, "frame": "no-such-frame"})
    yield _json("frame-10k", {**body, "frame": "f" * 10_000})
    yield _json("joint-names-unknown", {**body, "q": {"no-such-joint": 1.0}})
    yield _json("json-array", [body])
    yield _json("json-number", 3)
    yield ("not-json", b"{", JSON)
    yield ("empty", b"", JSON)
    yield ("deep-nesting", b"[" * 20_000 + b"]" * 20_000, JSON)
    yield ("not-utf8", b'{"q": "\xff\xfe"}', JSON)
    yield ("text-plain", json.dumps(body).encode(), {"Content-Type": "text/plain"})
    yield from _binary_variants(body)
    binary = BINARY
    yield ("binary-garbage", b"RDY1\x10\x00\x00\x00" + b"\xff" * 40, binary)
    header = json.dumps({"fields": {}, "arrays": {"q": {"shape": [0, 2**63], "offset": 0}}})
    yield (
        "binary-huge-shape",
        b"RDY1" + len(header).to_bytes(4, "little") + header.encode() + b"\0" * 64,
        binary,
    )
    yield ("binary-short", b"RDY", binary)
