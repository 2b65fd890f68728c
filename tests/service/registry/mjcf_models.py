"""Hand-written MJCF descriptions and their URDF twins, for the MJCF upload tests.

Each MJCF here describes the same rigid bodies as the URDF beside it, written the way a MuJoCo
user would (degrees by default, w-first quaternions, Euler sequences, geoms for inertia), so that
equal dynamics over HTTP show that robodyn reads MJCF right.
"""

from __future__ import annotations

import numpy as np

from robots import CATALOG_DIR


def _rpy(r: float, p: float, y: float) -> np.ndarray:
    """URDF's fixed-axis roll-pitch-yaw rotation Rz(y) Ry(p) Rx(r)."""
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return (
        np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
        @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
        @ np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    )


PLANAR_ARM_URDF = (CATALOG_DIR / "textbook" / "planar_arm.urdf").read_text()

# robots/textbook/planar_arm.urdf by hand: joint axes -y, point masses at the link tips (MuJoCo
# refuses moving bodies whose inertia is below mjMINVAL = 1e-15 kg·m²: they carry 1e-14).
PLANAR_ARM_MJCF = """<mujoco model="planar_arm">
  <compiler angle="radian"/>
  <worldbody>
    <body name="link1">
      <joint name="shoulder" type="hinge" axis="0 -1 0" range="-3.14159 3.14159"/>
      <inertial pos="1 0 0" mass="2" diaginertia="1e-14 1e-14 1e-14"/>
      <body name="link2" pos="1 0 0">
        <joint name="elbow" type="hinge" axis="0 -1 0" range="-3.14159 3.14159"/>
        <inertial pos="0.7 0 0" mass="1.5" diaginertia="1e-14 1e-14 1e-14"/>
        <site name="tip" pos="0.7 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

# A spatial arm: rotated joint frames, a rotated full inertia tensor and a prismatic joint.
SPATIAL_ARM_URDF = """<?xml version="1.0"?>
<robot name="spatial_arm">
  <link name="base"/>
  <link name="upper"><inertial><origin xyz="0.02 0.01 0.2" rpy="0.1 0.2 0.3"/>
    <mass value="2.0"/>
    <inertia ixx="0.03" ixy="0.001" ixz="-0.002" iyy="0.025" iyz="0.0015" izz="0.01"/>
  </inertial></link>
  <link name="fore"><inertial><origin xyz="0.15 0 0"/><mass value="1.2"/>
    <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <link name="slider"><inertial><origin xyz="0.05 0 0"/><mass value="0.5"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial></link>
  <joint name="yaw" type="revolute"><parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="50" velocity="3"/></joint>
  <joint name="pitch" type="revolute"><parent link="upper"/><child link="fore"/>
    <origin xyz="0 0.05 0.4" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="30" velocity="3"/></joint>
  <joint name="extend" type="prismatic"><parent link="fore"/><child link="slider"/>
    <origin xyz="0.3 0 0" rpy="0 0.5 0.25"/><axis xyz="1 0 0"/>
    <limit lower="-0.1" upper="0.2" effort="100" velocity="1"/></joint>
</robot>
"""

# The same in MuJoCo's units: degrees (the default), and URDF's fixed-axis roll-pitch-yaw
# (r, p, y) as rotating-axis Euler angles z-y-x (y, p, r). MuJoCo takes a full inertia tensor
# only in the body frame (not with an orientation): the URDF's tensor rotated by its rpy.
_UPPER = (
    _rpy(0.1, 0.2, 0.3)
    @ np.array([[0.03, 0.001, -0.002], [0.001, 0.025, 0.0015], [-0.002, 0.0015, 0.01]])
    @ _rpy(0.1, 0.2, 0.3).T
)
_UPPER_FULL = " ".join(
    repr(float(_UPPER[i, j])) for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
)
SPATIAL_ARM_MJCF = """<mujoco model="spatial_arm">
  <compiler eulerseq="zyx"/>
  <worldbody>
    <body name="upper" pos="0 0 0.1">
      <joint name="yaw" axis="0 0 1" range="-171.88733853924697 171.88733853924697"/>
      <inertial pos="0.02 0.01 0.2" mass="2.0" fullinertia="UPPER_FULL"/>
      <body name="fore" pos="0 0.05 0.4" euler="0 0 90">
        <joint name="pitch" axis="0 0 1" range="-114.59155902616465 114.59155902616465"/>
        <inertial pos="0.15 0 0" mass="1.2" diaginertia="0.002 0.01 0.01"/>
        <body name="slider" pos="0.3 0 0" euler="14.32394487827058 28.64788975654116 0">
          <joint name="extend" type="slide" axis="1 0 0" range="-0.1 0.2"/>
          <inertial pos="0.05 0 0" mass="0.5" diaginertia="0.001 0.001 0.001"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
""".replace("UPPER_FULL", _UPPER_FULL)

# A free-floating body with an arm: MJCF's <freejoint/> against URDF with root_joint free-flyer.
FLOATING_URDF = """<robot name="floating">
  <link name="torso"><inertial><origin xyz="0 0 0"/><mass value="4"/>
    <inertia ixx="0.05" ixy="0" ixz="0" iyy="0.06" iyz="0" izz="0.07"/></inertial></link>
  <link name="arm"><inertial><origin xyz="0.2 0 0"/><mass value="1"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="torso"/><child link="arm"/>
    <origin xyz="0.1 0 0.05"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="5"/></joint>
</robot>
"""


def floating_mjcf(free_joint: bool, torso_pos: str = "0 0 0") -> str:
    joint = '<freejoint name="root"/>' if free_joint else ""
    return f"""<mujoco model="floating">
  <compiler angle="radian"/>
  <worldbody>
    <body name="torso" pos="{torso_pos}">
      {joint}
      <inertial pos="0 0 0" mass="4" diaginertia="0.05 0.06 0.07"/>
      <body name="arm" pos="0.1 0 0.05">
        <joint name="shoulder" axis="0 1 0" range="-2 2"/>
        <inertial pos="0.2 0 0" mass="1" diaginertia="0.001 0.01 0.01"/>
      </body>
    </body>
  </worldbody>
  <keyframe><key name="home" qpos="0.1 0.2 0.9 1 0 0 0 0.5"/></keyframe>
</mujoco>
"""


# Two hinges on one body (a composite joint) against a URDF chain through a massless link.
GIMBAL_MJCF = """<mujoco model="gimbal">
  <compiler angle="radian"/>
  <worldbody>
    <body name="link" pos="0 0 0.2">
      <joint name="ax" axis="1 0 0"/>
      <joint name="ay" axis="0 1 0"/>
      <inertial pos="0.1 0.05 0.3" mass="1.5" diaginertia="0.02 0.03 0.04"/>
    </body>
  </worldbody>
</mujoco>
"""
GIMBAL_URDF = """<robot name="gimbal">
  <link name="base"/><link name="mid"/>
  <link name="link"><inertial><origin xyz="0.1 0.05 0.3"/><mass value="1.5"/>
    <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.04"/></inertial></link>
  <joint name="ax" type="revolute"><parent link="base"/><child link="mid"/>
    <origin xyz="0 0 0.2"/><axis xyz="1 0 0"/>
    <limit lower="-10" upper="10" effort="1" velocity="1"/></joint>
  <joint name="ay" type="revolute"><parent link="mid"/><child link="link"/>
    <axis xyz="0 1 0"/><limit lower="-10" upper="10" effort="1" velocity="1"/></joint>
</robot>
"""

# Inertia from geoms: a box (density 800, half sizes 0.1, 0.05, 0.2) and a 1 kg sphere (and a
# visual box of density 0: visual geoms weigh as any other in MuJoCo), against
# the same solids' closed-form inertias in URDF (box: m/12 (b² + c²), ...; sphere: 2/5 m r²).
GEOMS_MJCF = """<mujoco model="geoms">
  <compiler angle="radian"/>
  <default><geom density="800"/></default>
  <worldbody>
    <body name="block" pos="0 0 0.1">
      <joint name="hinge" axis="0 1 0"/>
      <geom type="box" size="0.1 0.05 0.2" pos="0 0 0.3"/>
      <geom type="sphere" size="0.05" mass="1" pos="0.2 0 0"/>
      <geom type="box" size="0.3 0.3 0.3" contype="0" conaffinity="0" density="0"/>
    </body>
  </worldbody>
</mujoco>
"""
_BOX_MASS = 800 * 0.2 * 0.1 * 0.4
GEOMS_URDF = f"""<robot name="geoms">
  <link name="base"/>
  <link name="block"><inertial><origin xyz="0 0 0.3"/><mass value="{_BOX_MASS}"/>
    <inertia ixx="{_BOX_MASS / 12 * (0.1**2 + 0.4**2)}" ixy="0" ixz="0"
             iyy="{_BOX_MASS / 12 * (0.2**2 + 0.4**2)}" iyz="0"
             izz="{_BOX_MASS / 12 * (0.2**2 + 0.1**2)}"/></inertial></link>
  <link name="ball"><inertial><origin xyz="0 0 0"/><mass value="1"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial></link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="block"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>
    <limit lower="-10" upper="10" effort="1" velocity="1"/></joint>
  <joint name="ball_fixed" type="fixed"><parent link="block"/><child link="ball"/>
    <origin xyz="0.2 0 0"/></joint>
</robot>
"""

# Several joints on one body (hinge off the body origin, slide, ball), a default class, a site,
# a geom-inertia child and a keyframe; served as a chain of one-joint bodies.
MULTI_JOINT_MJCF = """<mujoco model="multi">
  <default><default class="arm"><joint damping="0.1" armature="0.02"/></default></default>
  <worldbody>
    <body name="torso" pos="0 0 1" euler="0 20 0" childclass="arm">
      <joint name="hip_x" axis="1 0 0" pos="0 0.1 0" range="-60 60"/>
      <joint type="slide" axis="0 0 1" range="-0.1 0.1"/>
      <joint name="hip_ball" type="ball"/>
      <inertial pos="0.1 0 -0.2" mass="3" fullinertia="0.2 0.25 0.1 0.01 0 -0.02"/>
      <site name="grip" pos="0 0 -0.4"/>
      <body name="shin" pos="0 0 -0.4">
        <joint name="knee" axis="0 1 0" pos="0 0 0.05"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.04"/>
      </body>
    </body>
  </worldbody>
  <keyframe><key name="bent" qpos="0.1 0.05 0.9238795 0 0.3826834 0 -0.5"/></keyframe>
</mujoco>
"""

TWINS = {  # name → (MJCF, URDF, root_joint of the URDF)
    "planar_arm": (PLANAR_ARM_MJCF, PLANAR_ARM_URDF, "fixed"),
    "spatial_arm": (SPATIAL_ARM_MJCF, SPATIAL_ARM_URDF, "fixed"),
    "gimbal": (GIMBAL_MJCF, GIMBAL_URDF, "fixed"),
    "geoms": (GEOMS_MJCF, GEOMS_URDF, "fixed"),
}
