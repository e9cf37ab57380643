"""The reference controller's steering for the sphere (``agent.body: sphere``): the same planner,
without the gait.

The reference (aaai.task.reference) plans on the grid and steers by (forward, turn, crouch)
commands. For the quadruped a gait turns them into leg movements; the sphere takes them as they
are (aaai.agent.sphere), but it is eight times as fast and slides: its velocity follows its
heading only at the drag's rate, so a command meant for a walking body would carry it past its
goal and into walls. ``SphereSteer`` stands where the gait stands in the reference:

- ``command(forward, turn)`` (the reference's manoeuvres: backing off, turning on the spot, edging
  out from beside a wall, waiting) is read as the gait's own speeds, ``forward`` x WALK units/s
  and ``turn`` x GAIT_TURN, and the sphere is pushed or stopped to go that fast;
- ``drive(...)`` (the way to a goal) goes at the sphere's own speed: it turns straight at the next
  point of the plan, stops (Animal-AI's quick stop: no forward command) while it faces more than
  FACE away or while it drifts sideways, and pushes up to a speed that lets it stop within the
  room it has: the way still to go, and the clearance round it.
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p

from aaai.agent.sphere import STOP_RATE, TURN_RATE, Sphere
from aaai.sim.gait import load_parameters

WALK = 3.2  # units/s: the gait's speed at forward 1, what a manoeuvre's forward means
GAIT_TURN = math.radians(80.0)  # rad/s: the gait's turning at turn 1
FACE = math.radians(35.0)  # it pushes only while facing the next point this squarely
DRIFT = 1.5  # units/s sideways: more than this and it stops pushing until the drift is gone
STOP_MARGIN = 0.6  # it goes at most this fraction of the speed from which it could stop in the room left


class SphereSteer:
    """The gait's interface, as the reference uses it, for the sphere."""

    def __init__(self, env):
        self.env = env
        self.parameters = load_parameters()  # the approach's crouch distance (crouch is ignored)
        self.reset()

    @property
    def body(self) -> Sphere:
        body = self.env.body
        assert isinstance(body, Sphere)
        return body

    def reset(self, seed: int | None = None) -> None:
        self.target = (0.0, 0.0, 0.0)

    def _velocity(self) -> tuple[float, float]:
        """(along the heading, to its left), units/s."""
        body = self.body
        (vx, vy, _), _ = p.getBaseVelocity(body.id, physicsClientId=body.client)
        c, s = math.cos(body.yaw), math.sin(body.yaw)
        return vx * c + vy * s, -vx * s + vy * c

    def _push(self, along: float, speed: float) -> float:
        """The forward command that brings the speed along the heading to ``speed`` (units/s, signed)."""
        top = self.body.top_speed
        if abs(speed) < 0.05:
            return 0.0
        if (speed > 0 and along > speed + 0.5) or (speed < 0 and along < speed - 0.5):
            return 0.0  # too fast: the quick stop
        if abs(along) < 0.9 * abs(speed):
            return math.copysign(1.0, speed)  # accelerate at full push
        return max(-1.0, min(1.0, speed / top))

    def command(self, forward: float, turn: float, crouch: float = 0.0) -> None:
        along, _ = self._velocity()
        turn_command = max(-1.0, min(1.0, turn * GAIT_TURN / TURN_RATE))
        self.target = (self._push(along, max(-1.0, min(1.0, forward)) * WALK), turn_command, 0.0)

    def drive(self, error: float, distance: float, room: float) -> None:
        """Towards a point ``error`` rad to the left and ``distance`` away along the plan, with
        ``room`` units of clearance here."""
        along, side = self._velocity()
        step = self.env.hold * self.env.control_dt  # how long the command is held
        turn = max(-1.0, min(1.0, error / (TURN_RATE * step)))
        if abs(error) > FACE or abs(side) > DRIFT:
            self.target = (0.0, turn, 0.0)
            return
        room_left = max(0.0, min(distance, room))
        speed = min(self.body.top_speed, STOP_MARGIN * STOP_RATE * room_left)
        self.target = (self._push(along, max(speed, WALK * 0.5)), turn, 0.0)

    def stand(self) -> np.ndarray:
        self.target = (0.0, 0.0, 0.0)
        return np.zeros(0, np.float32)

    def __call__(self, observation=None) -> np.ndarray:
        """The reference returns ``target`` to a sphere's environment; no joint action exists."""
        return np.zeros(0, np.float32)
