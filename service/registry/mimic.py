"""The mimic graph of a URDF: which joint copies the motion of which, and what is refused.

`<mimic joint="B"/>` in joint A says A moves as multiplier · B + offset. Robodyn serves every
joint with its own coordinate (the relation is not imposed), but refuses graphs that cannot
mean anything: a joint mimicking itself, a joint mimicking a fixed joint (no motion to copy),
and cycles (A mimics B mimics … mimics A: no joint of the cycle moves on its own).
"""

from __future__ import annotations

from xml.etree.ElementTree import Element

from service.registry.safe_xml import shown

MimicProblem = tuple[str, str, str]  # (code, joint name, message)


def mimic_problems(joints: dict[str, Element], mimics: dict[str, str]) -> list[MimicProblem]:
    """What is wrong with the mimic graph (joint → the joint it mimics): a joint that mimics
    itself, a joint that mimics a fixed joint (which has no motion to copy), and cycles of
    mimics (A mimics B mimics … mimics A: no joint of the cycle has a motion of its own)."""
    out: list[MimicProblem] = []
    for jname, target in mimics.items():
        label = shown(jname)
        if target == jname:
            out.append(("self_mimic", jname, f"joint '{label}': mimics itself"))
        elif joints[target].get("type") == "fixed":
            out.append(
                (
                    "mimic_of_fixed_joint",
                    jname,
                    f"joint '{label}': mimics joint '{shown(target)}', which is fixed (it "
                    "has no motion to copy)",
                )
            )
    done: set[str] = set()
    for start in mimics:  # each joint mimics at most one: follow the chain, iteratively
        path: list[str] = []
        on_path: set[str] = set()
        joint: str | None = start
        while joint is not None and joint not in done and joint not in on_path:
            path.append(joint)
            on_path.add(joint)
            joint = mimics.get(joint)
        if joint is not None and joint in on_path and mimics.get(joint) != joint:
            cycle = path[path.index(joint) :]
            shown_cycle = " → ".join(f"'{shown(j)}'" for j in [*cycle[:6], cycle[0]])
            out.append(
                (
                    "mimic_cycle",
                    joint,
                    f"joint '{shown(joint)}': its mimics form a cycle ({shown_cycle}"
                    f"{' …' if len(cycle) > 6 else ''}); one joint of a mimic chain must "
                    "move on its own",
                )
            )
        done.update(path)
    return out
