"""A corpus of malformed and hostile upload bodies, each with its expected answer.

Every case is a body for `POST /v1/robots` (a dict sent as JSON, or raw bytes) with the status,
error `code` and a fragment of the detail that the answer must have. Accepted cases (201) carry
checks on the stored model instead. Used in-process by `test_corpus.py` and against a real
server by `test_corpus_server.py`.
"""

from __future__ import annotations

import base64
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from service.settings import Settings

UPLOAD_LIMIT = Settings.model_fields["max_upload_bytes"].default  # the default limit, bytes
INERTIA = "<inertia ixx='0.01' ixy='0' ixz='0' iyy='0.01' iyz='0' izz='0.01'/>"
LIMIT = "<limit lower='-1' upper='1' effort='10' velocity='2'/>"


def body_link(name: str = "b", mass: str = "1", inertia: str = INERTIA, extra: str = "") -> str:
    return f"<link name='{name}'><inertial><mass value='{mass}'/>{inertia}</inertial>{extra}</link>"


def joint(
    name: str = "j",
    parent: str = "a",
    child: str = "b",
    jtype: str = "revolute",
    inner: str = f"<axis xyz='0 0 1'/>{LIMIT}",
) -> str:
    return (
        f"<joint name='{name}' type='{jtype}'><parent link='{parent}'/>"
        f"<child link='{child}'/>{inner}</joint>"
    )


def robot(*parts: str, name: str = "r") -> str:
    return f"<robot name='{name}'>{''.join(parts)}</robot>"


def arm(
    *,
    link_extra: str = "",
    joint_inner: str = f"<axis xyz='0 0 1'/>{LIMIT}",
    mass: str = "1",
    inertia: str = INERTIA,
    name: str = "r",
) -> str:
    """A valid one-joint arm with one thing changed."""
    return robot(
        "<link name='a'/>",
        body_link(mass=mass, inertia=inertia, extra=link_extra),
        joint(inner=joint_inner),
        name=name,
    )


def tensor(ixx: float, iyy: float, izz: float, ixy: float = 0.0) -> str:
    return f"<inertia ixx='{ixx}' ixy='{ixy}' ixz='0' iyy='{iyy}' iyz='0' izz='{izz}'/>"


def chain(n: int, *, flat: bool = False, jtype: str = "revolute") -> str:
    links = ["<link name='l0'/>"] + [body_link(f"l{i}") for i in range(1, n + 1)]
    joints = [joint(f"j{i}", f"l{0 if flat else i - 1}", f"l{i}", jtype) for i in range(1, n + 1)]
    return robot(*links, *joints, name=f"chain{n}")


def tree(n: int, branching: int = 3) -> str:
    """n revolute joints in a tree: joint i's parent link is link (i − 1) // branching (link 0
    is the root), so every link carries `branching` children until the joints run out."""
    links = ["<link name='l0'/>"] + [body_link(f"l{i}") for i in range(1, n + 1)]
    joints = [joint(f"j{i}", f"l{(i - 1) // branching}", f"l{i}") for i in range(1, n + 1)]
    return robot(*links, *joints, name=f"tree{n}")


def nested(depth: int) -> str:
    return arm(link_extra="<x>" * depth + "</x>" * depth)


BILLION_LAUGHS = (
    "<?xml version='1.0'?><!DOCTYPE lolz [<!ENTITY lol 'lol'>"
    + "".join(
        f"<!ENTITY lol{i} '{('&lol' + str(i - 1) + ';') * 10}'>" for i in range(1, 10)
    ).replace("&lol0;", "&lol;")
    + "]><robot name='&lol9;'><link name='a'/></robot>"
)


def _b64(data: bytes) -> str:
    return base64.b64encode(data).decode()


STL = _b64(b"solid s\nfacet normal 0 0 1\nendsolid s\n")
MJCF_ARM = (
    "<mujoco model='m'><worldbody><body name='b'><joint name='j'/>"
    "<geom size='0.1'/></body></worldbody></mujoco>"
)


@dataclass(frozen=True)
class Case:
    id: str
    category: str
    body: dict[str, Any] | bytes
    status: int
    code: str | None = None
    fragment: str | None = None
    # for accepted uploads: a check on the RobotInfo answer
    accepted: Callable[[dict[str, Any]], bool] | None = field(default=None, compare=False)

    def content(self) -> bytes:
        if isinstance(self.body, bytes):
            return self.body
        return json.dumps(self.body).encode()


def _u(urdf: str, **options: Any) -> dict[str, Any]:
    return {"urdf": urdf, **options}


def _bad(case_id: str, category: str, urdf: str, fragment: str, **options: Any) -> Case:
    return Case(case_id, category, _u(urdf, **options), 422, "invalid_model", fragment)


CASES: list[Case] = [
    # -- malformed XML ---------------------------------------------------------------------
    _bad("not-xml", "malformed", "this is not xml", "not well-formed"),
    _bad("empty", "malformed", "", "not well-formed"),
    _bad("truncated", "malformed", "<robot name='x'><link name='a'/>", "not well-formed"),
    _bad(
        "mismatched-tags",
        "malformed",
        "<robot name='x'><link name='a'></joint></robot>",
        "mismatched tag",
    ),
    _bad("two-documents", "malformed", "<robot name='a'/><robot name='b'/>", "not well-formed"),
    _bad("nul-character", "malformed", arm(name="a\x00b"), "not well-formed"),
    _bad("control-character", "malformed", arm(name="a\x01b"), "not well-formed"),
    Case(
        "lone-surrogate",
        "malformed",
        b'{"urdf": "<robot name=\\"\\ud800\\"><link name=\\"a\\"/></robot>"}',
        422,
        "validation_error",
        "urdf",
    ),
    # -- wrong root ------------------------------------------------------------------------
    _bad("root-model", "wrong-root", "<model name='x'><link name='a'/></model>", "<model>"),
    _bad("root-mujoco", "wrong-root", "<mujoco model='x'><worldbody/></mujoco>", "<mujoco>"),
    _bad("root-sdf", "wrong-root", "<sdf version='1.6'><model name='x'/></sdf>", "<sdf>"),
    # -- missing, duplicate, cyclic structure ------------------------------------------------
    _bad("no-robot-name", "structure", "<robot><link name='a'/></robot>", "no name"),
    _bad("no-links", "structure", "<robot name='x'/>", "no <link>"),
    _bad("unnamed-link", "structure", "<robot name='x'><link/></robot>", "has no name"),
    _bad(
        "duplicate-link",
        "structure",
        robot("<link name='a'/>", "<link name='a'/>"),
        "link name 'a' is used twice",
    ),
    _bad(
        "duplicate-joint",
        "structure",
        robot(
            "<link name='a'/>",
            body_link("b"),
            body_link("c"),
            joint("j", "a", "b"),
            joint("j", "a", "c"),
        ),
        "joint name 'j' is used twice",
    ),
    _bad(
        "missing-child",
        "structure",
        robot("<link name='a'/>", joint(child="ghost")),
        "child link 'ghost' does not exist",
    ),
    _bad(
        "missing-parent",
        "structure",
        robot(body_link("b"), joint(parent="ghost")),
        "parent link 'ghost' does not exist",
    ),
    _bad(
        "no-child-element",
        "structure",
        robot("<link name='a'/>", "<joint name='j' type='fixed'><parent link='a'/></joint>"),
        "needs <parent link=...> and <child link=...>",
    ),
    _bad("two-roots", "structure", robot("<link name='a'/>", "<link name='b'/>"), "2 root links"),
    _bad(
        "pure-cycle",
        "structure",
        robot(body_link("a"), body_link("b"), joint("j1", "a", "b"), joint("j2", "b", "a")),
        "cycle",
    ),
    _bad(
        "cycle-beside-root",
        "structure",
        robot(
            "<link name='r0'/>",
            body_link("b"),
            body_link("c"),
            joint("j1", "b", "c"),
            joint("j2", "c", "b"),
        ),
        "not connected to the root 'r0' (a cycle)",
    ),
    _bad(
        "two-parents",
        "structure",
        robot(
            "<link name='a'/>",
            "<link name='c'/>",
            body_link("b"),
            joint("j1", "a", "b"),
            joint("j2", "c", "b"),
        ),
        "link 'b' is the child of two joints",
    ),
    _bad(
        "unknown-joint-type",
        "structure",
        arm().replace("'revolute'", "'hinge'"),
        "type 'hinge' is not one of",
    ),
    _bad(
        "dangling-mimic",
        "structure",
        arm(joint_inner=f"<axis xyz='0 0 1'/>{LIMIT}<mimic joint='ghost'/>"),
        "mimics joint 'ghost', which does not exist",
    ),
    _bad(
        "revolute-without-limit",
        "structure",
        arm(joint_inner="<axis xyz='0 0 1'/>"),
        "needs a <limit",
    ),
    _bad(
        "limit-without-effort",
        "structure",
        arm(joint_inner="<axis xyz='0 0 1'/><limit lower='-1' upper='1' velocity='1'/>"),
        "<limit> needs an effort attribute",
    ),
    # -- bad numbers in every attribute ------------------------------------------------------
    _bad("mass-nan", "numbers", arm(mass="nan"), "link 'b' mass value must be finite"),
    _bad("mass-inf", "numbers", arm(mass="-inf"), "link 'b' mass value must be finite"),
    _bad("mass-overflow", "numbers", arm(mass="1e400"), "link 'b' mass value must be finite"),
    _bad("mass-text", "numbers", arm(mass="heavy"), "link 'b' mass value is not a number"),
    _bad("mass-underscore", "numbers", arm(mass="1_000"), "link 'b' mass value is not a number"),
    _bad("mass-arabic-digit", "numbers", arm(mass="\u0661"), "mass value is not a number"),
    _bad("mass-hex", "numbers", arm(mass="0x10"), "mass value is not a number"),
    _bad("mass-two-values", "numbers", arm(mass="1 2"), "must have 1 number, found 2"),
    _bad(
        "inertia-nan",
        "numbers",
        arm(inertia=tensor(float("nan"), 1, 1)),
        "link 'b' inertia ixx must be finite",
    ),
    _bad(
        "inertia-missing-component",
        "numbers",
        arm(inertia="<inertia ixx='1' iyy='1' izz='1'/>"),
        "link 'b' inertia ixy is missing",
    ),
    _bad(
        "origin-two-numbers",
        "numbers",
        arm(joint_inner=f"<origin xyz='1 2'/><axis xyz='0 0 1'/>{LIMIT}"),
        "joint 'j' origin xyz must have 3 numbers, found 2",
    ),
    _bad(
        "origin-rpy-inf",
        "numbers",
        arm(joint_inner=f"<origin rpy='0 0 inf'/><axis xyz='0 0 1'/>{LIMIT}"),
        "joint 'j' origin rpy must be finite",
    ),
    _bad(
        "inertial-origin-text",
        "numbers",
        robot(
            "<link name='a'/>",
            "<link name='b'><inertial><origin xyz='a b c'/>"
            f"<mass value='1'/>{INERTIA}</inertial></link>",
            joint(),
        ),
        "link 'b' inertial origin xyz is not a number",
    ),
    _bad(
        "axis-zero",
        "numbers",
        arm(joint_inner=f"<axis xyz='0 0 0'/>{LIMIT}"),
        "joint 'j': axis is zero",
    ),
    _bad(
        "axis-nan",
        "numbers",
        arm(joint_inner=f"<axis xyz='nan 0 1'/>{LIMIT}"),
        "joint 'j' axis xyz must be finite",
    ),
    _bad(
        "limit-text",
        "numbers",
        arm(
            joint_inner="<axis xyz='0 0 1'/><limit lower='low' upper='1' effort='1' velocity='1'/>"
        ),
        "joint 'j' limit lower is not a number",
    ),
    _bad(
        "limit-velocity-inf",
        "numbers",
        arm(joint_inner="<axis xyz='0 0 1'/><limit effort='1' velocity='inf'/>"),
        "joint 'j' limit velocity must be finite",
    ),
    _bad(
        "damping-nan",
        "numbers",
        arm(joint_inner=f"<axis xyz='0 0 1'/>{LIMIT}<dynamics damping='nan'/>"),
        "joint 'j' dynamics damping must be finite",
    ),
    _bad(
        "mimic-multiplier-text",
        "numbers",
        robot(
            "<link name='a'/>",
            body_link("b"),
            body_link("c"),
            joint("j1", "a", "b"),
            joint(
                "j2",
                "b",
                "c",
                inner=f"<axis xyz='0 0 1'/>{LIMIT}<mimic joint='j1' multiplier='x'/>",
            ),
        ),
        "joint 'j2' mimic multiplier is not a number",
    ),
    _bad(
        "box-size-two-numbers",
        "numbers",
        arm(link_extra="<visual><geometry><box size='1 1'/></geometry></visual>"),
        "link 'b' visual box size must have 3 numbers",
    ),
    _bad(
        "cylinder-radius-nan",
        "numbers",
        arm(
            link_extra="<collision><geometry><cylinder radius='nan' length='1'/></geometry>"
            "</collision>"
        ),
        "link 'b' collision cylinder radius must be finite",
    ),
    _bad(
        "rgba-three-numbers",
        "numbers",
        arm(
            link_extra="<visual><geometry><sphere radius='1'/></geometry><material name='m'>"
            "<color rgba='1 0 0'/></material></visual>"
        ),
        "material color rgba must have 4 numbers",
    ),
    # -- physically impossible inertias -----------------------------------------------------------
    _bad("negative-mass", "physics", arm(mass="-1"), "link 'b': mass -1 kg is negative"),
    _bad(
        "negative-principal-moment",
        "physics",
        arm(inertia=tensor(-0.02, 0.1, 0.1)),
        "link 'b': inertia has a negative principal moment -0.02 kg·m²",
    ),
    _bad(
        "triangle-inequality",
        "physics",
        arm(inertia=tensor(0.001, 0.001, 0.01)),
        "link 'b': principal moments 0.001, 0.001, 0.01 kg·m² violate the triangle inequality",
    ),
    _bad(
        "rejection-names-the-option",
        "physics",
        arm(inertia=tensor(0.001, 0.001, 0.01)),
        '"inertia_check": "warn"',
    ),
    Case(
        "findings-accepted-with-warn",
        "physics",
        _u(arm(inertia=tensor(0.001, 0.001, 0.01), name="warned"), inertia_check="warn"),
        201,
        accepted=lambda info: (
            [w["code"] for w in info["warnings"]] == ["triangle_inequality"]
            and info["warnings"][0]["name"] == "b"
        ),
    ),
    Case(
        "rounding-level-negative-is-fine",
        "physics",
        _u(
            arm(
                inertia=tensor(0.01, 0.01, -1e-9),
                name="rounding",
                joint_inner=f"<axis xyz='1 0 0'/>{LIMIT}",
            )
        ),
        201,
        accepted=lambda info: info["warnings"] == [],
    ),
    _bad(
        "massless-moving-subtree",
        "physics",
        robot("<link name='a'/>", "<link name='b'/>", joint()),
        "whose subtree has no mass",
    ),
    _bad(
        "inertial-without-inertia",
        "physics",
        robot(
            "<link name='a'/>",
            "<link name='b'><inertial><mass value='1'/></inertial></link>",
            joint(),
        ),
        "needs an <inertia> element",
    ),
    _bad("singular-mass-matrix", "physics", arm(inertia=tensor(0, 0, 0)), "positive definite"),
    # -- XML bombs and external entities ---------------------------------------------------------
    _bad("billion-laughs", "entities", BILLION_LAUGHS, "DTD, entity or external reference"),
    _bad(
        "external-entity",
        "entities",
        "<!DOCTYPE r [<!ENTITY x SYSTEM 'file:///etc/passwd'>]><robot name='&x;'>"
        "<link name='a'/></robot>",
        "DTD, entity or external reference",
    ),
    _bad(
        "external-dtd",
        "entities",
        "<!DOCTYPE robot SYSTEM 'http://127.0.0.1:9/robot.dtd'><robot name='x'>"
        "<link name='a'/></robot>",
        "DTD, entity or external reference",
    ),
    _bad(
        "parameter-entity",
        "entities",
        "<!DOCTYPE r [<!ENTITY % p SYSTEM 'file:///etc/passwd'> %p;]><robot name='x'>"
        "<link name='a'/></robot>",
        "DTD, entity or external reference",
    ),
    Case(
        "xinclude-is-inert",
        "entities",
        _u(
            arm(
                name="xi",
                link_extra="<xi:include xmlns:xi='http://www.w3.org/2001/XInclude' "
                "href='/etc/passwd' parse='text'/>",
            )
        ),
        201,
        accepted=lambda info: "root:" not in json.dumps(info),
    ),
    # -- mesh paths pointing outside -------------------------------------------------------------
    Case(
        "mesh-parent-path",
        "meshes",
        _u(
            arm(
                name="mesh1",
                link_extra="<visual><geometry><mesh filename="
                "'../../../../../../etc/passwd'/></geometry></visual>",
            )
        ),
        201,
        accepted=lambda info: "root:" not in json.dumps(info),
    ),
    Case(
        "mesh-file-url",
        "meshes",
        _u(
            arm(
                name="mesh2",
                link_extra="<collision><geometry><mesh filename="
                "'file:///etc/shadow' scale='1 1 1'/></geometry></collision>",
            )
        ),
        201,
        accepted=lambda info: "root:" not in json.dumps(info),
    ),
    _bad(
        "mesh-scale-nan",
        "meshes",
        arm(
            link_extra="<visual><geometry><mesh filename='x.stl' scale='1 nan 1'/></geometry>"
            "</visual>"
        ),
        "link 'b' visual mesh scale must be finite",
    ),
    Case(
        "mesh-not-uploaded",
        "meshes",
        _u(
            arm(
                name="mesh3",
                link_extra="<visual><geometry><mesh filename="
                "'package://p/meshes/b.stl'/></geometry></visual>",
            )
        ),
        201,
        accepted=lambda info: (
            [(w["code"], w["file"], w["name"]) for w in info["warnings"]]
            == [("missing_mesh", "p/meshes/b.stl", "b")]
        ),
    ),
    # -- assets --------------------------------------------------------------------------------
    _bad(
        "asset-keys-of-2000-segments",
        "assets",
        arm(name="keys"),
        "2000 path segments; the limit is 32",
        assets={f"{i}/" + "s/" * 1998 + "x.stl": STL for i in range(50)},
    ),
    _bad(
        "asset-key-of-100k-characters",
        "assets",
        arm(name="keys"),
        "characters long; the limit is 1024",
        assets={"k" * 100_000 + ".stl": STL},
    ),
    _bad(
        "asset-gltf-nesting-bomb",
        "assets",
        arm(name="gltf"),
        "'m.gltf' is unreadable as .gltf: JSON nested deeper",
        assets={"m.gltf": _b64(b"[" * 200_000 + b"]" * 200_000)},
    ),
    _bad(
        "asset-xml-over-the-element-cap",
        "assets",
        arm(name="xml"),
        "'part.xml' is unreadable as .xml: it has more than 50000 XML elements",
        assets={"part.xml": _b64(b"<m>" + b"<a/>" * 250_000 + b"</m>")},
    ),
    _bad(
        "asset-xml-with-entities",
        "assets",
        arm(name="xml"),
        "'part.xml' is unreadable as .xml: XML with a DTD",
        assets={"part.xml": _b64(BILLION_LAUGHS.encode())},
    ),
    # -- huge and deeply nested files, long chains ------------------------------------------------
    _bad("xml-nesting", "huge", nested(40), "nested deeper than 32"),
    _bad("xml-nesting-very-deep", "huge", nested(100_000), "nested deeper than 32"),
    _bad("many-elements", "huge", arm(link_extra="<x/>" * 60_000), "more than 50000 XML"),
    _bad("too-many-links", "huge", chain(1001, flat=True, jtype="fixed"), "the limit is 1000"),
    _bad("nv-over-the-cap", "huge", chain(129, flat=True), "nv = 129"),
    _bad("long-chain", "huge", chain(129, jtype="fixed"), "deeper than 128 links"),
    _bad("native-crash-chain", "huge", chain(999, jtype="fixed"), "deeper than 128 links"),
    _bad(
        "huge-name-not-echoed",
        "huge",
        robot(f"<link name='{'n' * 100_000}'/>", f"<link name='{'n' * 100_000}'/>"),
        "100000 characters long; the limit is 256",
    ),
    Case(
        "body-over-the-upload-limit",
        "huge",
        _u(arm(link_extra=" " * UPLOAD_LIMIT)),
        413,
        "payload_too_large",
        "ROBODYN_MAX_UPLOAD_BYTES",
    ),
    Case("json-nesting-bomb", "huge", b"[" * 200_000, 422, "validation_error", "nested too deeply"),
    Case(
        "json-body-not-utf8",
        "unicode",
        b'{"urdf": "\xff\xfe"}',
        422,
        "validation_error",
        "not UTF-8",
    ),
    # -- unicode and odd encodings ---------------------------------------------------------------
    Case(
        "unicode-names",
        "unicode",
        _u(
            robot(
                "<link name='基座'/>",
                body_link("腕 💪"),
                joint("関節 ✓", "基座", "腕 💪"),
                name="ロボット",
            )
        ),
        201,
        accepted=lambda info: (
            [j["name"] for j in info["joints"]] == ["関節 ✓"] and info["name"] == "ロボット"
        ),
    ),
    Case(
        "declared-latin1",
        "unicode",
        _u("<?xml version='1.0' encoding='ISO-8859-1'?>" + arm(name="café")),
        201,
        accepted=lambda info: info["name"] == "café",
    ),
    Case(
        "declared-utf16",
        "unicode",
        _u("<?xml version='1.0' encoding='UTF-16'?>" + arm(name="utf16")),
        201,
        accepted=lambda info: info["name"] == "utf16",
    ),
    Case(
        "byte-order-mark",
        "unicode",
        _u("\ufeff" + arm(name="bom")),
        201,
        accepted=lambda info: info["name"] == "bom",
    ),
    Case(
        "rtl-override-name",
        "unicode",
        _u(arm(name="evil\u202etxt.exe")),
        201,
        accepted=lambda info: info["name"] == "evil\u202etxt.exe",
    ),
    # -- the request around the description ------------------------------------------------------
    Case("urdf-not-a-string", "request", {"urdf": 42}, 422, "validation_error", "urdf"),
    Case(
        "unknown-root-joint",
        "request",
        _u(arm(), root_joint="ball"),
        422,
        "validation_error",
        "root_joint",
    ),
    Case(
        "gravity-nan",
        "request",
        b'{"urdf": "<robot/>", "gravity": [0, 0, NaN]}',
        422,
        "validation_error",
        "gravity",
    ),
    Case(
        "unknown-option",
        "request",
        _u(arm(), inertia_check="ignore"),
        422,
        "validation_error",
        "inertia_check",
    ),
    # the cost of refusing is bounded by what the answer says (tests/hardening/floods.py for
    # the dynamics routes)
    Case(
        "unknown-members-by-the-100000",
        "huge",
        _u(arm(), **{f"m{i}": 1 for i in range(100_000)}),
        422,
        "validation_error",
        "has 100000 members that are not fields of this request",
    ),
    Case(
        "megabyte-member-name",
        "request",
        _u(arm(), **{"x" * 1_000_000: 1}),
        422,
        "validation_error",
        "x" * 64 + "…: is not a field",
    ),
    Case(
        "assets-of-100000-numbers",
        "huge",
        _u(arm(), assets={f"m{i}.stl": i for i in range(100_000)}),
        422,
        "validation_error",
        "must be a valid string",
    ),
    Case(
        "locked-joint-of-100000-strings",
        "huge",
        _u(arm(), locked_joints={"j": ["x"] * 100_000}),
        422,
        "validation_error",
        "locked_joints",
    ),
    # -- MJCF numbers MuJoCo's compiler accepts -------------------------------------------------
    Case(
        "mjcf-nan-gravity",
        "numbers",
        {"mjcf": MJCF_ARM.replace("<worldbody>", "<option gravity='nan 0 0'/><worldbody>")},
        422,
        "invalid_model",
        "<option gravity> holds a non-finite number",
    ),
    Case(
        "mjcf-nan-keyframe",
        "numbers",
        {
            "mjcf": MJCF_ARM.replace(
                "</mujoco>", "<keyframe><key name='k' qpos='nan'/></keyframe></mujoco>"
            )
        },
        422,
        "invalid_model",
        "<key name='k'> qpos holds a non-finite number",
    ),
]

assert len({c.id for c in CASES}) == len(CASES), "case ids must be unique"
