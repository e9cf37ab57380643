"""Animal-AI's own body: a sphere that slides forward and backward and turns (``agent.body: sphere``).

Animal-AI's agent is a sphere of diameter 1 in an arena 40 across, with two actions: forward or
backward, and turn left or right. Its numbers, from Animal-AI's source and documentation
(``TrainingAgent.cs``, ``docs/Arena-Environment-Guide.md``), in Animal-AI's units:

- it turns at ``rotationSpeed`` = 100 degrees per second, by turning its transform (no angular
  momentum): a turn starts and stops at once;
- it is pushed along its heading against a linear drag of 1.2 per second, which gives it a top speed;
  measured on Animal-AI (a forward action held from rest), the speed rises as 1 - 0.885^n per 0.1 s
  towards about 21 units per second: a time constant of 1 / 1.2 s, the drag's;
- with no forward action its velocity is cut to 0.9 of itself every 0.02 s physics step
  (``quickStopRatio``), a stop within about half a second;
- its velocity is in the world: turning does not turn it (a turn at speed drifts, as there).

Here the sphere is sized as Animal-AI's is to its arena: its diameter is the arena's side over
40, and its top speed scales with it (21 x that scale, units/s); angles do not scale. In the
generated levels the arena is the levels' standard one, 50 across (diameter 1.25, 26 units/s), in
every level: where a level's arena is larger (L5 and L8 at higher difficulties, L9's 70 to give the
quadruped room to turn in a sector) the distances are part of the task, not a change of scale. An
arena file (hand-written or imported from Animal-AI, whose 40 becomes 200 at the importer's scale
5) sets it by its own larger side: diameter 5 and 105 units/s in a 200 arena. It is driven by velocity,
not by forces or torques: every control step its horizontal velocity is moved towards ``forward``
x top speed along its heading at the drag's rate (the quick-stop rate with ``forward`` 0), its
vertical velocity is left to physics up to a cap (it falls into holes, rides up slopes and steps), and
its heading turns by ``turn`` x 100 degrees per second; it never rolls (its orientation is its heading alone, set
each step; a sphere's shape does not change with it). It has no floor friction of its own; drag
stands for it, as in Animal-AI. It pushes what it runs into with its mass.

It keeps to the ground as Animal-AI's does. Its upward speed is capped at ``sqrt(g r)`` (``r`` its
radius, ``g`` the world's gravity; :func:`rise_speed`), from which a free rise is half its radius
(measured: 1.1 to 1.4 above a step's or a ramp's top for radius 2.5, never its radius). Without the
cap, the contact with the edge of a step lower than its radius turns its speed into an upward one: at
full speed a step 1 high threw it 55 above it, over the arena's walls. With it, it rolls up a step
lower than its radius, rides up a ramp onto what it leads to, and is stopped by a step as high as its
radius or higher; it falls freely.

Its proprioception (the observation's ``joints``, with the joint modes' names kept so that every
policy finds the same keys): its forward speed over its top speed and its turning rate over the
top rate, each in [-1, 1]; ``joint_velocities`` are the same two in units/s and rad/s. It has
one "foot": ``foot_contacts`` is 1 while it touches anything. It rests on its head: the floor
under it is no "head on the floor" (aaai.task.rewards).
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p

AAI_ARENA = 40.0  # Animal-AI's arena, units across
LEVEL_ARENA = 50.0  # the generated levels' standard arena, units across
AAI_DIAMETER = 1.0  # its agent's diameter
AAI_TOP_SPEED = 21.0  # units/s, its agent's top speed (forward held), in its own units
AAI_DRAG = 1.2  # per second: its agent's linear drag, the rate at which its speed follows the push
AAI_QUICK_STOP = 0.9  # with no forward action its velocity is multiplied by this every physics step
AAI_PHYSICS_STEP = 0.02  # s: Unity's fixed step, at which that stop is applied
TURN_RATE = math.radians(100.0)  # rad/s: its agent's rotationSpeed, 100 degrees per second
STOP_RATE = -math.log(AAI_QUICK_STOP) / AAI_PHYSICS_STEP  # per second, about 5.3
MASS = 8.5  # as the quadruped's, so that both push objects alike
SPAWN_GAP = 0.05  # spawned this far above the floor
AGENT_GROUP = 64  # as aaai.agent.body's: rays leave the body out
# The room its footprint keeps beyond its radius (aaai.levels.validate's footprint): one cell of the
# validator's occupancy grid (its GRID), because the clearance there is measured between cell centres
# and a wall's face may lie up to a cell nearer; as the quadruped's footprint keeps 0.5 beyond the 4.5
# its resting legs reach, for the sweep of its feet.
FOOTPRINT_MARGIN = 0.5
COMMAND_NAMES = ("forward", "turn")
PROPRIOCEPTION = ("forward_speed", "turn_rate")


def scale_for(arena_size=None) -> float:
    """How many of our units one of Animal-AI's is in an arena of ``arena_size`` (its larger side over
    40), or in the generated levels' standard arena (None)."""
    if arena_size is None:
        return LEVEL_ARENA / AAI_ARENA
    return max(float(arena_size[0]), float(arena_size[1])) / AAI_ARENA


def rise_speed(radius: float, gravity: float) -> float:
    """The upward speed the sphere of ``radius`` keeps at most under ``gravity``: sqrt(g r), from which
    a free rise is r / 2. Enough to roll up a step lower than its radius (the contact lifts it), never
    enough to fly; 0 without gravity."""
    return math.sqrt(max(gravity, 0.0) * radius)


def footprint_radius(arena_size=None) -> float:
    """The radius of the disc the sphere needs clear round its centre (a start, a passage) in an arena of
    ``arena_size`` (None: the generated levels'): its own radius there plus FOOTPRINT_MARGIN."""
    return round(AAI_DIAMETER / 2 * scale_for(arena_size) + FOOTPRINT_MARGIN, 4)


class Sphere:
    """The sphere in one client, with the quadruped's interface (aaai.agent.body.Quadruped) where
    it has a meaning. ``load`` after every resetSimulation, with the arena's size."""

    drive = "velocity"

    def __init__(self, client: int, control_dt: float, visuals: bool = True):
        self.client = client
        self.control_dt = control_dt
        self.visuals = visuals
        self.id = -1
        self.joint_names = list(PROPRIOCEPTION)  # what the observation's ``joints`` holds
        self.joint_ids: list[int] = []
        self.n_axes = len(PROPRIOCEPTION)
        self.lower, self.upper = -np.ones(self.n_axes), np.ones(self.n_axes)
        self.links, self.link_names = [-1], ["head"]
        self.foot_links, self.foot_slot = [-1], {-1: 0}  # it touches things with itself
        self.scale = 1.0
        self.radius = AAI_DIAMETER / 2
        self.top_speed = AAI_TOP_SPEED
        self.yaw = 0.0
        self._turn_rate = 0.0
        self.rise_speed = rise_speed(self.radius, 9.81)

    def fit(self, arena_size=None) -> None:
        """Sizes the sphere and its top speed for an arena file's arena, or for the generated levels
        (None), as Animal-AI's agent is to its own."""
        self.scale = scale_for(arena_size)
        self.radius = AAI_DIAMETER / 2 * self.scale
        self.top_speed = AAI_TOP_SPEED * self.scale

    @property
    def footprint(self) -> float:
        """The footprint radius it is validated with at its present size (:func:`footprint_radius`)."""
        return round(self.radius + FOOTPRINT_MARGIN, 4)

    def load(self, x: float, y: float, yaw: float, arena_size=None) -> int:
        c = self.client
        self.fit(arena_size)
        collision = p.createCollisionShape(p.GEOM_SPHERE, radius=self.radius, physicsClientId=c)
        visual = (
            p.createVisualShape(p.GEOM_SPHERE, radius=self.radius, rgbaColor=(0.85, 0.55, 0.25, 1), physicsClientId=c)
            if self.visuals
            else -1
        )
        self.yaw = float(yaw)
        self.id = p.createMultiBody(
            MASS,
            collision,
            visual,
            basePosition=(x, y, self.radius + SPAWN_GAP),
            baseOrientation=p.getQuaternionFromEuler((0, 0, self.yaw)),
            physicsClientId=c,
        )
        p.setCollisionFilterGroupMask(self.id, -1, AGENT_GROUP, 0xFFFF, physicsClientId=c)
        p.changeDynamics(
            self.id,
            -1,
            lateralFriction=0.0,
            rollingFriction=0.0,
            spinningFriction=0.0,
            linearDamping=0.0,
            angularDamping=0.0,
            physicsClientId=c,
        )
        self._turn_rate = 0.0
        gravity = -p.getPhysicsEngineParameters(physicsClientId=c)["gravityAccelerationZ"]
        self.rise_speed = rise_speed(self.radius, gravity)
        return self.id

    def rest_action(self) -> np.ndarray:
        return np.zeros(len(COMMAND_NAMES))

    def apply(self, action: np.ndarray) -> None:
        """One control step with commands (forward, turn), each in [-1, 1]: the velocity
        follows the push along the heading, the heading turns, the upward speed is capped."""
        forward, turn = float(action[0]), float(action[1])
        c, dt = self.client, self.control_dt
        (vx, vy, vz), _ = p.getBaseVelocity(self.id, physicsClientId=c)
        rate = AAI_DRAG if abs(forward) > 1e-3 else STOP_RATE
        keep = math.exp(-rate * dt)
        push = forward * self.top_speed * (1.0 - keep) if rate == AAI_DRAG else 0.0
        self._turn_rate = turn * TURN_RATE
        self.yaw = (self.yaw + self._turn_rate * dt + math.pi) % (2 * math.pi) - math.pi
        vx = vx * keep + push * math.cos(self.yaw)
        vy = vy * keep + push * math.sin(self.yaw)
        vz = min(vz, self.rise_speed)  # the edge of a step turns the push upwards: it may not throw it
        position, _ = p.getBasePositionAndOrientation(self.id, physicsClientId=c)
        p.resetBasePositionAndOrientation(
            self.id, position, p.getQuaternionFromEuler((0, 0, self.yaw)), physicsClientId=c
        )
        p.resetBaseVelocity(self.id, (vx, vy, vz), (0.0, 0.0, 0.0), physicsClientId=c)

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Its proprioception: (forward speed / top speed, turn rate / top rate) clipped to [-1, 1],
        and the same in units/s and rad/s."""
        (vx, vy, _), _ = p.getBaseVelocity(self.id, physicsClientId=self.client)
        speed = vx * math.cos(self.yaw) + vy * math.sin(self.yaw)
        speeds = np.array([speed, self._turn_rate])
        scaled = np.array([speed / self.top_speed, self._turn_rate / TURN_RATE])
        return np.minimum(np.maximum(scaled, -1.0), 1.0), speeds

    def head_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Centre (3,) and rotation matrix (3, 3) whose columns are its x (heading), y, z axes."""
        position, orientation = p.getBasePositionAndOrientation(self.id, physicsClientId=self.client)
        return np.array(position), np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)

    def leg_points(self) -> list:
        return []

    def contacts(self) -> list[tuple]:
        return p.getContactPoints(bodyA=self.id, physicsClientId=self.client)

    def blew_up(self, joint_speeds: np.ndarray, position, bound: float, max_speed_sq: float) -> bool:
        """As the quadruped's, with the speed limit at least twice its own top speed (a sphere
        scaled to a large arena is faster than a walking body)."""
        (vx, vy, vz), _ = p.getBaseVelocity(self.id, physicsClientId=self.client)
        x, y, z = position
        limit = max(max_speed_sq, (2 * self.top_speed) ** 2)
        healthy = vx * vx + vy * vy + vz * vz <= limit and -bound <= x <= bound and -bound <= y <= bound and z <= bound
        return not healthy


class SphereCommands:
    """The sphere's counterpart of the gait (aaai.sim.gait.SineGait) in the environment: it holds
    the commands (forward, turn; crouch is accepted and has no effect, the sphere's eye is already
    at the floor) and passes them to the body unchanged, without blending: the body's own drag is
    its inertia, as in Animal-AI."""

    def __init__(self) -> None:
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        self.forward = self.turn = self.crouch = 0.0
        self.target = (0.0, 0.0, 0.0)

    def command(self, forward: float, turn: float, crouch: float = 0.0) -> None:
        self.target = (
            min(max(float(forward), -1.0), 1.0),
            min(max(float(turn), -1.0), 1.0),
            min(max(float(crouch), 0.0), 1.0),
        )
        self.forward, self.turn, self.crouch = self.target

    def __call__(self, observation=None) -> np.ndarray:
        return np.array([self.forward, self.turn])
