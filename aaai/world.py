"""Builds a LevelSpec into a PyBullet client and runs its moving parts.

Every body carries a kind (aaai.kinds); rays and rewards read it from ``kind_index``.
The floor is one body made of tiles (holes are tiles left out), or a heightfield for rough
terrain; a deadly floor far below the arena catches anything that falls. Moving parts (the
behaviours of aaai.spec) advance by simulated time only; one with nothing left to do is dropped,
so a level without moving parts costs nothing per step.
"""
from __future__ import annotations

import math

import numpy as np
import pybullet as p

from aaai.geometry import footprint, merge_tiles
from aaai.kinds import COLOURS, KIND_INDEX
from aaai.spec import LevelSpec, ObjectSpec

FLOOR_THICKNESS = 1.0
DEADLY_FLOOR_TOP = -6.0
DEADLY_FLOOR_SIZE = 400.0
NO_KIND = -1
MAX_COMPOUND_SHAPES = 16  # PyBullet's limit on shapes in one createCollisionShapeArray
RANDOM_WALK_TURN = 2.0  # heading noise of a random walk, rad per sqrt(s)
# Bullet multiplies the two bodies' frictions; the floor's default is 0.5. A plank must grip the
# floor (1.0 combined) or a body climbing onto the L10 bridge shoves it into the trench.
PLANK_FRICTION = 2.0
HIDDEN_Z = -30.0  # where an open door waits: below the deadly floor, out of sight and reach


class Sink:
    """Moves a body straight down by ``depth`` over ``duration`` simulated seconds."""

    def __init__(self, obj: ObjectSpec):
        self.start, self.yaw = obj.position, obj.yaw
        self.depth, self.duration = obj.behaviour["depth"], obj.behaviour["duration"]

    def pose(self, time: float, dt: float) -> tuple[tuple[float, float, float], bool]:
        """The position at ``time`` and whether it has arrived."""
        done = time >= self.duration
        fraction = 1.0 if done else time / self.duration
        x, y, z = self.start
        return (x, y, z - self.depth * fraction), done


class Slide:
    """Moves a body in a straight line to a target at a constant speed, then stops."""

    def __init__(self, obj: ObjectSpec):
        self.x, self.y, self.z = obj.position
        self.yaw = obj.yaw
        self.target = tuple(obj.behaviour["to"])
        self.speed = obj.behaviour["speed"]

    def pose(self, time: float, dt: float) -> tuple[tuple[float, float, float], bool]:
        dx, dy = self.target[0] - self.x, self.target[1] - self.y
        remaining, step = math.hypot(dx, dy), self.speed * dt
        if remaining <= step:
            self.x, self.y = self.target
            return (self.x, self.y, self.z), True
        self.x, self.y = self.x + dx / remaining * step, self.y + dy / remaining * step
        return (self.x, self.y, self.z), False


class Door:
    """A wall hidden until the agent's head is past ``distance`` along ``direction`` and inside
    that direction's 90-degree sector; then it stands at its place for good."""

    def __init__(self, obj: ObjectSpec):
        self.obj = obj
        self.position, self.yaw = obj.position, obj.yaw
        self.ux, self.uy = obj.behaviour["direction"]
        self.distance = obj.behaviour["distance"]

    def entered(self, head_x: float, head_y: float) -> bool:
        along = head_x * self.ux + head_y * self.uy
        across = abs(head_y * self.ux - head_x * self.uy)
        return along > self.distance and across < along


class World:
    """The level's bodies in one client. Build it after every resetSimulation."""

    def __init__(self, client: int, spec: LevelSpec, motion_rng: np.random.Generator, visuals: bool = True):
        self.client = client
        self.visuals = visuals  # without them building is faster; nothing can be drawn
        self.spec = spec
        self.motion_rng = motion_rng
        self.kind_index = np.full(64, NO_KIND, dtype=np.int64)  # body id -> index into KINDS
        self.objects: dict[int, ObjectSpec] = {}
        self.food: dict[int, ObjectSpec] = {}
        self.walkers: dict[int, list[float]] = {}  # body id -> [x, y, z, heading]
        self.movers: dict[int, Sink | Slide] = {}  # sinking pillars and their food, sliding food
        self.doors: dict[int, Door] = {}  # open doors, closed by the head position advance() is given
        self.closed: list[Door] = []  # doors that have closed: food outside their sectors is out of reach
        self.time = 0.0  # simulated seconds since the build
        self.colours = {**COLOURS, **{kind: tuple(rgba) for kind, rgba in spec.extras.get("colours", {}).items()}}
        self._shapes: dict[tuple, tuple[int, int]] = {}
        self._build_floor()
        self._build_deadly_floor()
        for obj in spec.objects:
            self._build_object(obj)
        self.had_food = bool(self.food)
        self._eaten: bool | None = None  # all_eaten's answer, until food is eaten or a door closes
        self._obstacles = [  # footprints that random walkers steer clear of
            footprint(obj) for obj in spec.objects
            if not obj.is_food and obj.mass == 0 and _inside_arena(obj, spec)
        ]

    # --- building -------------------------------------------------------------------
    def _register(self, body: int, kind: str) -> None:
        if body >= len(self.kind_index):
            grown = np.full(max(2 * len(self.kind_index), body + 1), NO_KIND, dtype=np.int64)
            grown[: len(self.kind_index)] = self.kind_index
            self.kind_index = grown
        self.kind_index[body] = KIND_INDEX[kind]

    def _build_floor(self) -> None:
        """The floor's tiles, merged into as few boxes as can be, in bodies of up to 16 boxes."""
        c, spec = self.client, self.spec
        if spec.heightfield is not None:
            self._build_terrain()
            return
        nx, ny = spec.tiles
        tile_x, tile_y = spec.arena_size[0] / nx, spec.arena_size[1] / ny
        boxes = []
        for i0, j0, i1, j1 in merge_tiles(nx, ny, set(map(tuple, spec.holes))):
            centre = (-spec.arena_size[0] / 2 + (i0 + i1) / 2 * tile_x,
                      -spec.arena_size[1] / 2 + (j0 + j1) / 2 * tile_y, -FLOOR_THICKNESS / 2)
            half = ((i1 - i0) * tile_x / 2, (j1 - j0) * tile_y / 2, FLOOR_THICKNESS / 2)
            boxes.append((centre, half))
        for start in range(0, len(boxes), MAX_COMPOUND_SHAPES):
            chunk = boxes[start:start + MAX_COMPOUND_SHAPES]
            count = len(chunk)
            centres, halves = [list(b[0]) for b in chunk], [list(b[1]) for b in chunk]
            collision = p.createCollisionShapeArray([p.GEOM_BOX] * count, halfExtents=halves,
                                                    collisionFramePositions=centres, physicsClientId=c)
            visual = p.createVisualShapeArray([p.GEOM_BOX] * count, halfExtents=halves,
                                              visualFramePositions=centres,
                                              rgbaColors=[self.colours["floor"]] * count,
                                              physicsClientId=c) if self.visuals else -1
            self._register(p.createMultiBody(0, collision, visual, useMaximalCoordinates=True, physicsClientId=c),
                           "floor")

    def _build_terrain(self) -> None:
        """Rough terrain: the spec's heightfield (rows along y, columns along x) over the arena.

        Bullet centres a heightfield on its body between the lowest and highest sample, so the
        body sits at that middle height for the samples to land at their own heights.
        """
        c, spec = self.client, self.spec
        heights = np.asarray(spec.heightfield, dtype=np.float64)
        rows, cols = heights.shape
        scale = [spec.arena_size[0] / (cols - 1), spec.arena_size[1] / (rows - 1), 1.0]
        collision = p.createCollisionShape(p.GEOM_HEIGHTFIELD, meshScale=scale, heightfieldData=heights.ravel().tolist(),
                                           numHeightfieldRows=cols, numHeightfieldColumns=rows, physicsClientId=c)
        middle = (heights.min() + heights.max()) / 2
        body = p.createMultiBody(0, collision, basePosition=(0, 0, middle), physicsClientId=c)
        if self.visuals:
            p.changeVisualShape(body, -1, rgbaColor=self.colours["floor"], physicsClientId=c)
        self._register(body, "floor")

    def _build_deadly_floor(self) -> None:
        c = self.client
        half = [DEADLY_FLOOR_SIZE / 2, DEADLY_FLOOR_SIZE / 2, 0.5]
        collision = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=c)
        visual = p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=self.colours["deadly_floor"],
                                     physicsClientId=c) if self.visuals else -1
        body = p.createMultiBody(0, collision, visual, basePosition=(0, 0, DEADLY_FLOOR_TOP - 0.5),
                                 useMaximalCoordinates=True, physicsClientId=c)
        self._register(body, "deadly_floor")

    def _shape(self, obj: ObjectSpec) -> tuple[int, int]:
        """Collision and visual shapes for an object, made once per (shape, size, colour)."""
        key = (obj.shape, obj.size, obj.rgba)
        if key not in self._shapes:
            c = self.client
            if obj.shape == "box":
                geometry = dict(shapeType=p.GEOM_BOX, halfExtents=[s / 2 for s in obj.size])
            elif obj.shape == "sphere":
                geometry = dict(shapeType=p.GEOM_SPHERE, radius=obj.size[0] / 2)
            else:
                geometry = dict(shapeType=p.GEOM_CYLINDER, radius=obj.size[0] / 2)
            collision_extra = {"height": obj.size[2]} if obj.shape == "cylinder" else {}
            visual_extra = {"length": obj.size[2]} if obj.shape == "cylinder" else {}
            collision = p.createCollisionShape(**geometry, **collision_extra, physicsClientId=c)
            visual = p.createVisualShape(**geometry, **visual_extra, rgbaColor=obj.rgba,
                                         physicsClientId=c) if self.visuals else -1
            self._shapes[key] = (collision, visual)
        return self._shapes[key]

    def _build_object(self, obj: ObjectSpec) -> int:
        c = self.client
        collision, visual = self._shape(obj)
        orientation = p.getQuaternionFromEuler((0, 0, obj.yaw))
        kind = obj.behaviour["type"] if obj.behaviour else None
        position = (*obj.position[:2], HIDDEN_Z) if kind == "door" else obj.position
        # Static bodies in maximal coordinates: plain rigid bodies, about twice as fast to create.
        body = p.createMultiBody(obj.mass, collision, visual, basePosition=position, baseOrientation=orientation,
                                 useMaximalCoordinates=obj.mass == 0, physicsClientId=c)
        self._register(body, obj.kind)
        if obj.kind == "plank":
            p.changeDynamics(body, -1, lateralFriction=PLANK_FRICTION, physicsClientId=c)
        self.objects[body] = obj
        if obj.is_food:
            self.food[body] = obj
        if kind == "random_walk":
            heading = float(self.motion_rng.uniform(-math.pi, math.pi))
            self.walkers[body] = [*obj.position, heading]
        elif kind == "sink":
            self.movers[body] = Sink(obj)
        elif kind == "slide":
            self.movers[body] = Slide(obj)
        elif kind == "door":
            self.doors[body] = Door(obj)
        elif kind == "hinge":
            self._pin(body, obj)
        return body

    def _pin(self, body: int, obj: ObjectSpec) -> None:
        """Pins a body to the world at its behaviour's two pivot points: a hinge about their line."""
        c, s = math.cos(obj.yaw), math.sin(obj.yaw)
        for point in obj.behaviour["pivot"]:
            dx, dy, dz = (point[i] - obj.position[i] for i in range(3))
            local = (c * dx + s * dy, -s * dx + c * dy, dz)  # the point in the body's frame
            p.createConstraint(body, -1, -1, -1, p.JOINT_POINT2POINT, (0, 0, 0), local, tuple(point),
                               physicsClientId=self.client)

    # --- running --------------------------------------------------------------------
    def eat(self, eaten: dict[int, tuple[ObjectSpec, bool]]) -> None:
        """Takes the eaten yellow pieces (body -> (food, by the head)) out of the world; a green
        one ends the episode and stays."""
        for body, (food, _) in eaten.items():
            if food.kind != "food_green":
                self.remove(body)

    def food_positions(self) -> list[tuple[float, float, float]]:
        """Where each piece of food still in the world is now."""
        return [p.getBasePositionAndOrientation(body, physicsClientId=self.client)[0] for body in self.food]

    def remove(self, body: int) -> None:
        """Takes an object (an eaten food piece) out of the world."""
        p.removeBody(body, physicsClientId=self.client)
        self.kind_index[body] = NO_KIND
        self.objects.pop(body, None)
        self.food.pop(body, None)
        self.walkers.pop(body, None)
        self.movers.pop(body, None)
        self.doors.pop(body, None)
        self._eaten = None

    def advance(self, dt: float, head: tuple[float, float] | None = None) -> None:
        """Moves the moving parts by dt of simulated time. ``head`` (x, y) is needed while any
        door is open (``self.doors``)."""
        self.time += dt
        for body, state in self.walkers.items():
            self._walk(body, state, dt)
        if self.movers:
            self._move(dt)
        if self.doors and head is not None:
            self._close_doors(head)

    def _move(self, dt: float) -> None:
        """Sinking and sliding bodies to their poses at the new time; arrived ones stop."""
        arrived = []
        for body, mover in self.movers.items():
            position, done = mover.pose(self.time, dt)
            p.resetBasePositionAndOrientation(body, position, p.getQuaternionFromEuler((0, 0, mover.yaw)),
                                              physicsClientId=self.client)
            if done:
                arrived.append(body)
        for body in arrived:
            del self.movers[body]

    def _close_doors(self, head: tuple[float, float]) -> None:
        """Stands up the door of any sector the head has entered."""
        for body, door in list(self.doors.items()):
            if door.entered(head[0], head[1]):
                p.resetBasePositionAndOrientation(body, door.position, p.getQuaternionFromEuler((0, 0, door.yaw)),
                                                  physicsClientId=self.client)
                self.closed.append(door)
                del self.doors[body]
                self._eaten = None

    def all_eaten(self) -> bool:
        """Is no food left that the agent can still get to, in a level that had some? (Food shut
        out of the sector the agent is in, L9's behind a closed door, cannot be got to.) The answer
        changes only when food is eaten or a door closes, so it is worked out only then."""
        if self._eaten is None:
            self._eaten = self.had_food and not any(
                all(door.entered(*p.getBasePositionAndOrientation(body, physicsClientId=self.client)[0][:2])
                    for door in self.closed)
                for body in self.food)
        return self._eaten

    def _walk(self, body: int, state: list[float], dt: float) -> None:
        obj = self.objects[body]
        x, y, z, heading = state
        heading += RANDOM_WALK_TURN * math.sqrt(dt) * float(self.motion_rng.standard_normal())
        step = obj.behaviour["speed"] * dt
        nx, ny = x + step * math.cos(heading), y + step * math.sin(heading)
        if self._blocked(nx, ny, obj.size[0] / 2):
            heading += math.pi  # turn back; stay put this step
            nx, ny = x, y
        state[:] = [nx, ny, z, heading]
        p.resetBasePositionAndOrientation(body, (nx, ny, z), (0, 0, 0, 1), physicsClientId=self.client)

    def _blocked(self, x: float, y: float, radius: float) -> bool:
        """Would a disc at (x, y) leave the arena or overlap a static solid's footprint?"""
        half_x, half_y = self.spec.arena_size[0] / 2 - radius, self.spec.arena_size[1] / 2 - radius
        if not (-half_x <= x <= half_x and -half_y <= y <= half_y):
            return True
        return any(abs(x - ox) < hx + radius and abs(y - oy) < hy + radius for ox, oy, hx, hy in self._obstacles)


def _inside_arena(obj: ObjectSpec, spec: LevelSpec) -> bool:
    return abs(obj.position[0]) < spec.arena_size[0] / 2 and abs(obj.position[1]) < spec.arena_size[1] / 2
