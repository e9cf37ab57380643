"""Writes the quadruped URDF files shipped in aaai/urdf/.

The body: a head sphere and four two-segment legs lying as a flat X along
the diagonals. Geometry follows the original build: head radius 1.5 (mass
0.5); thighs and shins are capsules of radius 0.5 and total length 2 (mass 1),
thigh centres 2.0 and shin centres 3.5 from the head centre.

Two bodies are written:
- ``quadruped.urdf`` (8 axes, the default): each hip turns up/down (about the
  horizontal axis across the leg, [-90, 90] deg, positive = down), which lifts
  the head off the floor; each knee turns sideways (about the thigh's own
  vertical axis, [-45, 45] deg), which sweeps the foot to walk and turn.
- ``quadruped16.urdf`` (16 axes, the paper's body): every hip and knee has both
  an up/down and a sideways axis, joined by a massless-in-effect connector link.

Run ``python -m aaai.agent.urdf_writer`` to regenerate the files.
"""

from __future__ import annotations

import math
from pathlib import Path

HEAD_RADIUS = 1.5
HEAD_MASS = 0.5
SEGMENT_RADIUS = 0.5
SEGMENT_LENGTH = 2.0  # total, caps included
SEGMENT_MASS = 1.0
SEGMENT_CENTRE = SEGMENT_LENGTH / 2 - SEGMENT_RADIUS  # from a segment's pivot: its near cap is centred on the pivot
SEGMENT_TIP = SEGMENT_CENTRE + SEGMENT_LENGTH / 2  # from a segment's pivot to its far end
HIP_DISTANCE = 1.5  # hip pivot on the head's surface
KNEE_DISTANCE = 3.0  # knee pivot at the thigh's far end
LEG_REACH = KNEE_DISTANCE + SEGMENT_TIP  # a resting leg's tip from the head's centre
UPDOWN_LIMIT = math.radians(90)
SIDEWAYS_LIMIT = math.radians(45)
CONNECTOR_MASS = 1e-3

# name, angle of the leg's diagonal in the body frame (x forward, y left)
LEGS = (("fl", 45.0), ("fr", -45.0), ("bl", 135.0), ("br", -135.0))

COLOURS = {"head": "0.85 0.55 0.25 1", "thigh": "0.75 0.45 0.2 1", "shin": "0.6 0.35 0.15 1"}


def _fmt(*values: float) -> str:
    return " ".join(f"{v:.6g}" for v in values)


def _capsule_inertia(mass: float, radius: float, length: float) -> tuple[float, float, float]:
    """Inertia of a solid cylinder of the capsule's size, axis along the leg (x)."""
    axial = 0.5 * mass * radius**2
    transverse = mass * (3 * radius**2 + length**2) / 12
    return axial, transverse, transverse


def _segment_link(name: str, colour: str, visuals: bool) -> str:
    # A URDF capsule lies along its local z axis; rotate it onto the leg's x axis.
    cylinder_length = SEGMENT_LENGTH - 2 * SEGMENT_RADIUS
    ixx, iyy, izz = _capsule_inertia(SEGMENT_MASS, SEGMENT_RADIUS, SEGMENT_LENGTH)
    origin = f'<origin xyz="{_fmt(SEGMENT_CENTRE, 0, 0)}" rpy="0 {_fmt(math.pi / 2)} 0"/>'
    geometry = f'<geometry><capsule radius="{SEGMENT_RADIUS}" length="{cylinder_length}"/></geometry>'
    visual = (
        f'\n    <visual>{origin}{geometry}<material name="{name}_m"><color rgba="{colour}"/></material></visual>'
        if visuals
        else ""
    )
    return f"""  <link name="{name}">
    <inertial><origin xyz="{_fmt(SEGMENT_CENTRE, 0, 0)}"/><mass value="{SEGMENT_MASS}"/>
      <inertia ixx="{ixx:.6g}" iyy="{iyy:.6g}" izz="{izz:.6g}" ixy="0" ixz="0" iyz="0"/></inertial>{visual}
    <collision>{origin}{geometry}</collision>
  </link>
"""


def _connector_link(name: str) -> str:
    return f"""  <link name="{name}">
    <inertial><mass value="{CONNECTOR_MASS}"/>
      <inertia ixx="1e-5" iyy="1e-5" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
"""


def _joint(name: str, parent: str, child: str, xyz, rpy, axis, limit: float) -> str:
    return f"""  <joint name="{name}" type="revolute">
    <parent link="{parent}"/><child link="{child}"/>
    <origin xyz="{_fmt(*xyz)}" rpy="{_fmt(*rpy)}"/>
    <axis xyz="{_fmt(*axis)}"/>
    <limit lower="{-limit:.6g}" upper="{limit:.6g}" effort="1000" velocity="20"/>
  </joint>
"""


UPDOWN_AXIS = (0, 1, 0)  # leg frame: x along the leg, so +y rotation turns the leg down
SIDEWAYS_AXIS = (0, 0, 1)


def _pivot(prefix: str, parent: str, child: str, xyz, rpy, axes) -> str:
    """Joins parent to child by one or two revolute axes (adding connectors between)."""
    text = ""
    chain = [parent] + [f"{prefix}_link{i}" for i in range(len(axes) - 1)] + [child]
    for i, (suffix, axis, limit) in enumerate(axes):
        if 0 < i:
            xyz, rpy = (0, 0, 0), (0, 0, 0)
        if i < len(axes) - 1:
            text += _connector_link(chain[i + 1])
        text += _joint(f"{prefix}_{suffix}" if len(axes) > 1 else prefix, chain[i], chain[i + 1], xyz, rpy, axis, limit)
    return text


def quadruped_urdf(axes_per_joint: int, visuals: bool = True) -> str:
    """The body's URDF; without visuals it loads faster, for worlds that nothing renders."""
    updown = ("updown", UPDOWN_AXIS, UPDOWN_LIMIT)
    sideways = ("sideways", SIDEWAYS_AXIS, SIDEWAYS_LIMIT)
    hip_axes = [updown] if axes_per_joint == 1 else [updown, sideways]
    knee_axes = [sideways] if axes_per_joint == 1 else [updown, sideways]
    head_inertia = 0.4 * HEAD_MASS * HEAD_RADIUS**2
    name = "quadruped" if axes_per_joint == 1 else "quadruped16"
    head_visual = (
        f'    <visual><geometry><sphere radius="{HEAD_RADIUS}"/></geometry>'
        f'<material name="head_m"><color rgba="{COLOURS["head"]}"/></material></visual>\n'
        if visuals
        else ""
    )
    text = f"""<?xml version="1.0"?>
<!-- Generated by aaai/agent/urdf_writer.py; edit that file, not this one. -->
<robot name="{name}">
  <link name="head">
    <inertial><mass value="{HEAD_MASS}"/>
      <inertia ixx="{head_inertia:.6g}" iyy="{head_inertia:.6g}" izz="{head_inertia:.6g}" ixy="0" ixz="0" iyz="0"/></inertial>
{head_visual}    <collision><geometry><sphere radius="{HEAD_RADIUS}"/></geometry></collision>
  </link>
"""
    for leg, angle in LEGS:
        theta = math.radians(angle)
        hip_xyz = (HIP_DISTANCE * math.cos(theta), HIP_DISTANCE * math.sin(theta), 0)
        text += _segment_link(f"{leg}_thigh", COLOURS["thigh"], visuals)
        text += _pivot(f"{leg}_hip", "head", f"{leg}_thigh", hip_xyz, (0, 0, theta), hip_axes)
        text += _segment_link(f"{leg}_shin", COLOURS["shin"], visuals)
        knee_xyz = (KNEE_DISTANCE - HIP_DISTANCE, 0, 0)
        text += _pivot(f"{leg}_knee", f"{leg}_thigh", f"{leg}_shin", knee_xyz, (0, 0, 0), knee_axes)
    return text + "</robot>\n"


URDF_DIR = Path(__file__).resolve().parent.parent / "urdf"
AXES_PER_JOINT = {"quadruped": 1, "quadruped16": 2}
BODIES = tuple(AXES_PER_JOINT)  # the bodies config key agent.body may name


def file_name(body: str, visuals: bool) -> str:
    """quadruped.urdf, or quadruped_physics.urdf for the variant without visual shapes."""
    return f"{body}.urdf" if visuals else f"{body}_physics.urdf"


def all_files() -> dict[str, str]:
    """Every shipped URDF file name and its text."""
    return {
        file_name(body, visuals): quadruped_urdf(axes, visuals)
        for body, axes in AXES_PER_JOINT.items()
        for visuals in (True, False)
    }


def write_all(folder: Path = URDF_DIR) -> None:
    for name, text in all_files().items():
        (folder / name).write_text(text)


if __name__ == "__main__":
    write_all()
