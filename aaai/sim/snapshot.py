"""A running level at one moment as plain data: the agent's pose and legs, where each object is.

``AnimalAIEnv.snapshot()`` makes one; the viewer draws a level's spec and a snapshot without
PyBullet. Objects are named by their index in the spec's ``objects``.
"""

from __future__ import annotations

from dataclasses import dataclass

Point = tuple[float, float, float]  # world x, y, z


@dataclass(frozen=True)
class Pose:
    """A body's centre (x, y, z) and its heading: the yaw (radians) of its x axis about z."""

    x: float
    y: float
    z: float
    yaw: float


@dataclass(frozen=True)
class Leg:
    """One leg: its hip (the thigh's pivot), knee (the shin's pivot) and foot (the shin's far end)."""

    hip: Point
    knee: Point
    foot: Point


@dataclass(frozen=True)
class Snapshot:
    """The level at one moment (``AnimalAIEnv.snapshot``)."""

    time: float  # simulated seconds since the reset
    head: Pose  # the agent's head
    legs: tuple[Leg, ...]  # fl, fr, bl, br (aaai.agent.urdf_writer.LEGS); () for a body without them
    objects: tuple[Pose | None, ...]  # by index in the spec's objects: where each is now, None once removed (eaten)
    closed_doors: frozenset[int] = frozenset()  # indices of the doors that have risen (closed behind the agent)
    radius: float | None = None  # a body without legs (the sphere): its radius; None: the quadruped's head
