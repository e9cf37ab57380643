"""The quadruped in a PyBullet client: loading, driving its axes, reading its joints and contacts."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
import pybullet as p

from aaai.agent.urdf_writer import BODIES, HEAD_RADIUS, LEGS, SEGMENT_TIP, file_name
from aaai.errors import ConfigError

URDF_DIR = Path(__file__).resolve().parent.parent / "urdf"
SPAWN_HEIGHT = 1.5
AGENT_GROUP = 64  # collision group of the body's parts; rays leave it out
RAY_MASK = 0xFFFF & ~AGENT_GROUP
BLOWUP_JOINT_SPEED = 90.0  # rad/s; Bullet clamps joint speeds at 100


def urdf_path(body: str, visuals: bool = True) -> Path:
    if body not in BODIES:
        raise ConfigError(f"config key 'agent.body': got {body!r}; allowed: one of {', '.join(BODIES)}")
    path = URDF_DIR / file_name(body, visuals)
    if not path.is_file():
        raise FileNotFoundError(f"model file for agent.body={body!r} is missing: {path}")
    return path


Drive = Literal["angle", "velocity"]  # the motors' control: target angles (PyBullet's position control) or speeds


class Quadruped:
    """One body in one client. Load it with ``load`` after every resetSimulation.

    ``drive`` is how an action reaches the motors: ``"angle"`` (each axis to a target angle) or
    ``"velocity"`` (each axis at a target speed). It is the body's own setting, distinct from the
    environment's ``agent.action_mode``: both ``rotation`` and ``gait`` drive the body by angle."""

    def __init__(
        self,
        client: int,
        body: str,
        drive: Drive,
        max_force: float,
        max_joint_velocity: float,
        friction: float,
        visuals: bool = True,
        position_gain: float = 0.1,
        velocity_gain: float = 1.0,
    ):
        self.client = client
        self.path = str(urdf_path(body, visuals))
        self.drive: Drive = drive  # how an action drives the axes: target angles or target speeds
        self.max_force = max_force
        self.max_joint_velocity = max_joint_velocity
        self.friction = friction
        self.position_gain, self.velocity_gain = position_gain, velocity_gain
        self.id = -1
        self.radius = HEAD_RADIUS  # the head's: the senses start just outside it
        self._describe_joints()

    def _describe_joints(self) -> None:
        """Reads joint names and limits once, from a scratch client, so spaces exist before reset."""
        scratch = p.connect(p.DIRECT)
        try:
            body = p.loadURDF(self.path, physicsClientId=scratch)
            infos = [
                p.getJointInfo(body, j, physicsClientId=scratch)
                for j in range(p.getNumJoints(body, physicsClientId=scratch))
            ]
        finally:
            p.disconnect(scratch)
        revolute = [info for info in infos if info[2] == p.JOINT_REVOLUTE]
        self.joint_ids = [info[0] for info in revolute]
        self.joint_names = [info[1].decode() for info in revolute]
        self.lower = np.array([info[8] for info in revolute])
        self.upper = np.array([info[9] for info in revolute])
        self.links = [-1] + [info[0] for info in infos]  # -1 is the head
        self.link_names = ["head"] + [info[12].decode() for info in infos]
        self.foot_links = [info[0] for info in infos if info[12].decode().endswith("_shin")]
        self.foot_slot = {link: i for i, link in enumerate(self.foot_links)}
        self.n_axes = len(self.joint_ids)
        self._forces = [self.max_force] * self.n_axes
        self._position_gains = [self.position_gain] * self.n_axes
        self._velocity_gains = [self.velocity_gain] * self.n_axes
        self._half_range = 0.5 * (self.upper - self.lower)
        self._middle = self.lower + self._half_range

    def load(self, x: float, y: float, yaw: float, arena_size=None) -> int:
        """Loads the body at (x, y) facing ``yaw`` (its size does not depend on ``arena_size``)."""
        c = self.client
        orientation = p.getQuaternionFromEuler((0, 0, yaw))
        self.id = p.loadURDF(self.path, (x, y, SPAWN_HEIGHT), orientation, physicsClientId=c)
        for link in self.links:
            p.setCollisionFilterGroupMask(self.id, link, AGENT_GROUP, 0xFFFF, physicsClientId=c)
            p.changeDynamics(self.id, link, lateralFriction=self.friction, physicsClientId=c)
        self.apply(np.zeros(self.n_axes) if self.drive == "velocity" else self.rest_action())
        return self.id

    def rest_action(self) -> np.ndarray:
        """The action that holds every axis at its rest angle (0) with the angle drive."""
        return (-self.lower - self.upper) / (self.upper - self.lower)

    def apply(self, action: np.ndarray) -> None:
        """Sends one control step's commands: target angles (``drive="angle"``) or speeds (``"velocity"``)."""
        if self.drive == "angle":
            targets = self._middle + action * self._half_range
            p.setJointMotorControlArray(
                self.id,
                self.joint_ids,
                p.POSITION_CONTROL,
                targetPositions=targets.tolist(),
                forces=self._forces,
                positionGains=self._position_gains,
                velocityGains=self._velocity_gains,
                physicsClientId=self.client,
            )
        else:
            p.setJointMotorControlArray(
                self.id,
                self.joint_ids,
                p.VELOCITY_CONTROL,
                targetVelocities=(action * self.max_joint_velocity).tolist(),
                forces=self._forces,
                physicsClientId=self.client,
            )

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Angles normalised to [-1, 1] over each axis's range (0 at rest) and speeds in rad/s."""
        states = p.getJointStates(self.id, self.joint_ids, physicsClientId=self.client)
        angles = np.array([s[0] for s in states])
        speeds = np.array([s[1] for s in states])
        return np.minimum(np.maximum((angles - self._middle) / self._half_range, -1.0), 1.0), speeds

    def head_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Head centre (3,) and rotation matrix (3, 3) whose columns are the head's x, y, z axes."""
        position, orientation = p.getBasePositionAndOrientation(self.id, physicsClientId=self.client)
        rotation = np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)
        return np.array(position), rotation

    def leg_points(self) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Each leg's (fl, fr, bl, br) hip, knee and foot in the world, (3,) each: the thigh's and
        the shin's link frames and the shin's far end; [] for a body without those links."""
        links = dict(zip(self.link_names, self.links))
        legs = []
        for leg, _ in LEGS:
            thigh, shin = links.get(f"{leg}_thigh"), links.get(f"{leg}_shin")
            if thigh is None or shin is None:
                return []
            hip_state, knee_state = p.getLinkStates(
                self.id, [thigh, shin], computeForwardKinematics=True, physicsClientId=self.client
            )
            hip, knee = np.array(hip_state[4]), np.array(knee_state[4])
            along = np.array(p.getMatrixFromQuaternion(knee_state[5])).reshape(3, 3)[:, 0]
            legs.append((hip, knee, knee + SEGMENT_TIP * along))
        return legs

    def contacts(self) -> list[tuple]:
        """This step's contact points of the body with anything (PyBullet's tuples: [2] the other
        body, [3] this body's link, -1 the head). Read once per step; rewards and touch share it."""
        return p.getContactPoints(bodyA=self.id, physicsClientId=self.client)

    def blew_up(self, joint_speeds: np.ndarray, position, bound: float, max_speed_sq: float) -> bool:
        """A physics blow-up: a non-finite state, a body moving impossibly fast, or beyond ``bound``
        (a half-size) from the origin. Comparisons are written so that NaN fails them."""
        (vx, vy, vz), _ = p.getBaseVelocity(self.id, physicsClientId=self.client)
        x, y, z = position
        healthy = (
            vx * vx + vy * vy + vz * vz <= max_speed_sq
            and all(-BLOWUP_JOINT_SPEED <= speed <= BLOWUP_JOINT_SPEED for speed in joint_speeds.tolist())
            and -bound <= x <= bound
            and -bound <= y <= bound
            and z <= bound
        )
        return not healthy
