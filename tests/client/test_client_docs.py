"""docs/python-client.md describes the client's answer types as they are: every field of
`RobotInfo` (and of the types inside it) is named in the `robot(id)` row."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

from robodyn.models import Finding, FrameInfo, JointInfo, RobotInfo

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "python-client.md"


def test_the_robot_row_names_every_field_of_robot_info():
    row = next(
        line for line in GUIDE.read_text().splitlines() if line.startswith("| `robot(id)` |")
    )
    named = set(re.findall(r"`(\w+)", row))
    for cls in (RobotInfo, Finding, FrameInfo):
        missing = {f.name for f in dataclasses.fields(cls)} - named - {"raw"} | (
            {"raw"} - named if cls is RobotInfo else set()
        )
        assert not missing, (cls.__name__, sorted(missing))
    joint_fields = {"name", "type", "parent", "idx_q", "nq", "idx_v", "nv"}
    assert joint_fields <= {f.name for f in dataclasses.fields(JointInfo)}
    assert joint_fields <= named
    for extra in ("joint_names", "frame_names", "contact_frames", "joint"):
        assert hasattr(RobotInfo, extra) and extra in named, extra
