"""Builds a LevelSpec into a PyBullet client and runs its moving parts.

Every body carries a kind (aaai.spec.kinds); rays and rewards read it from ``kind_index``.
The floor is one body made of tiles (holes are tiles left out), or a heightfield for rough
terrain; a deadly floor far below the arena catches anything that falls. Moving parts (the
behaviours of aaai.spec.behaviours) advance by simulated time only; one with nothing left to do is dropped,
so a level without moving parts costs nothing per step.
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p

from aaai.sim.geometry import Bounds, merge_tiles
from aaai.sim.snapshot import Pose
from aaai.spec import LevelSpec, ObjectSpec
from aaai.spec.behaviours import Behaviour, Door, behaviour_class
from aaai.spec.kinds import CAMERA_HIDDEN, COLOURS, ENDING_KINDS, KIND_INDEX, SOLID_KINDS, kind_class

FLOOR_THICKNESS = 1.0
DEADLY_FLOOR_TOP = -6.0
DEADLY_FLOOR_SIZE = 400.0
NO_KIND = -1
MAX_COMPOUND_SHAPES = 16  # PyBullet's limit on shapes in one createCollisionShapeArray
# Bullet multiplies the two bodies' frictions; the floor's default is 0.5. A plank must grip the
# floor (1.0 combined) or a body climbing onto the L10 bridge shoves it into the trench.
PLANK_FRICTION = 2.0
HIDDEN_VISUAL = 1e-3  # radius of the visual shape of a kind the camera does not see
HIDDEN_Z = -30.0  # where an open door waits: below the deadly floor, out of sight and reach


class World:
    """The level's bodies in one client. Build it after every resetSimulation."""

    def __init__(self, client: int, spec: LevelSpec, motion_rng: np.random.Generator, visuals: bool | str = True):
        self.client = client
        self.visuals = bool(visuals)  # without them building is faster; nothing can be drawn
        # the camera's look (sensors.camera_look): "task" hides what the task says is not seen
        self.look = visuals if isinstance(visuals, str) and visuals else "classic"
        self.spec = spec
        self.motion_rng = motion_rng
        self.kind_index = np.full(64, NO_KIND, dtype=np.int64)  # body id -> index into KINDS
        self.objects: dict[int, ObjectSpec] = {}
        self.food: dict[int, ObjectSpec] = {}
        self.running: dict[int, Behaviour] = {}  # body id -> its moving part, while it has work left
        self.closed: list[Door] = []  # doors that have closed: food outside their sectors is out of reach
        self.closed_bodies: list[int] = []  # their bodies
        self.time = 0.0  # simulated seconds since the build
        self.colours = {**COLOURS, **{kind: tuple(rgba) for kind, rgba in spec.colours.items()}}
        self._shapes: dict[tuple, tuple[int, int]] = {}
        self._build_floor()
        self._build_deadly_floor()
        self.index: dict[int, int] = {}  # body id -> the object's index in spec.objects
        for i, obj in enumerate(spec.objects):
            self.index[self._build_object(obj)] = i
        self.had_food = any(obj.is_food for obj in self.food.values())
        # the multi_food rule: the episode ends once every piece of such a kind is eaten
        self.all_end = {obj.kind for obj in self.food.values() if getattr(kind_class(obj.kind), "all_end", False)}
        self._eaten: bool | None = None  # all_eaten's answer, until food is eaten or a door closes
        self.bounds = Bounds(spec)  # what random walkers and bouncing pieces steer clear of

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
        for i0, j0, i1, j1 in merge_tiles(nx, ny, {(i, j) for i, j in spec.holes}):
            centre = (
                -spec.arena_size[0] / 2 + (i0 + i1) / 2 * tile_x,
                -spec.arena_size[1] / 2 + (j0 + j1) / 2 * tile_y,
                -FLOOR_THICKNESS / 2,
            )
            half = ((i1 - i0) * tile_x / 2, (j1 - j0) * tile_y / 2, FLOOR_THICKNESS / 2)
            boxes.append((centre, half))
        for start in range(0, len(boxes), MAX_COMPOUND_SHAPES):
            chunk = boxes[start : start + MAX_COMPOUND_SHAPES]
            count = len(chunk)
            centres, halves = [list(b[0]) for b in chunk], [list(b[1]) for b in chunk]
            collision = p.createCollisionShapeArray(
                [p.GEOM_BOX] * count, halfExtents=halves, collisionFramePositions=centres, physicsClientId=c
            )
            visual = (
                p.createVisualShapeArray(
                    [p.GEOM_BOX] * count,
                    halfExtents=halves,
                    visualFramePositions=centres,
                    rgbaColors=[self.colours["floor"]] * count,
                    physicsClientId=c,
                )
                if self.visuals
                else -1
            )
            self._register(
                p.createMultiBody(0, collision, visual, useMaximalCoordinates=True, physicsClientId=c), "floor"
            )

    def _build_terrain(self) -> None:
        """Rough terrain: the spec's heightfield (rows along y, columns along x) over the arena.

        Bullet centres a heightfield on its body between the lowest and highest sample, so the
        body sits at that middle height for the samples to land at their own heights.
        """
        c, spec = self.client, self.spec
        heights = np.asarray(spec.heightfield, dtype=np.float64)
        rows, cols = heights.shape
        scale = [spec.arena_size[0] / (cols - 1), spec.arena_size[1] / (rows - 1), 1.0]
        collision = p.createCollisionShape(
            p.GEOM_HEIGHTFIELD,
            meshScale=scale,
            heightfieldData=heights.ravel().tolist(),
            numHeightfieldRows=cols,
            numHeightfieldColumns=rows,
            physicsClientId=c,
        )
        middle = (heights.min() + heights.max()) / 2
        body = p.createMultiBody(0, collision, basePosition=(0, 0, middle), physicsClientId=c)
        if self.visuals:
            # textureUniqueId -1: TinyRenderer draws a checker texture over the colour otherwise
            texture = {"textureUniqueId": -1} if self.look == "task" else {}
            p.changeVisualShape(body, -1, rgbaColor=self.colours["floor"], **texture, physicsClientId=c)
        self._register(body, "floor")

    def _build_deadly_floor(self) -> None:
        c = self.client
        half = [DEADLY_FLOOR_SIZE / 2, DEADLY_FLOOR_SIZE / 2, 0.5]
        collision = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=c)
        visual = (
            p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=self.colours["deadly_floor"], physicsClientId=c)
            if self.visuals
            else -1
        )
        body = p.createMultiBody(
            0,
            collision,
            visual,
            basePosition=(0, 0, DEADLY_FLOOR_TOP - 0.5),
            useMaximalCoordinates=True,
            physicsClientId=c,
        )
        self._register(body, "deadly_floor")

    def _shape(self, obj: ObjectSpec) -> tuple[int, int]:
        """Collision and visual shapes for an object, made once per (shape, size, colour, kind seen)."""
        hidden = obj.kind in CAMERA_HIDDEN and self.look == "task"
        key = (obj.shape, obj.size, obj.rgba, hidden)
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
            visual = -1
            if self.visuals and hidden:  # a speck inside the body: TinyRenderer ignores alpha, and draws
                # a body without any visual shape from its collision shape
                visual = p.createVisualShape(p.GEOM_SPHERE, radius=HIDDEN_VISUAL, rgbaColor=obj.rgba, physicsClientId=c)
            elif self.visuals:
                visual = p.createVisualShape(**geometry, **visual_extra, rgbaColor=obj.rgba, physicsClientId=c)
            self._shapes[key] = (collision, visual)
        return self._shapes[key]

    def _kind_shape(self, obj: ObjectSpec) -> tuple[int, int]:
        """Shapes for a newer kind (aaai.spec.kinds): its boxes, its mesh, or its one shape (a floor
        area as a slab ZONE_THICKNESS thick)."""
        cls = kind_class(obj.kind)
        assert cls is not None  # called for the newer kinds only (build)
        hidden = obj.kind in CAMERA_HIDDEN and self.look == "task"
        key = (obj.kind, obj.shape, obj.size, obj.rgba, hidden)
        if key in self._shapes:
            return self._shapes[key]
        c = self.client
        parts, mesh = cls.parts(obj), cls.mesh(obj)
        visual = -1
        if parts:
            count = len(parts)
            centres = [list(centre) for centre, _, _ in parts]
            halves = [[v / 2 for v in size] for _, size, _ in parts]
            turns = [list(p.getQuaternionFromEuler((roll, 0, 0))) for _, _, roll in parts]
            collision = p.createCollisionShapeArray(
                [p.GEOM_BOX] * count,
                halfExtents=halves,
                collisionFramePositions=centres,
                collisionFrameOrientations=turns,
                physicsClientId=c,
            )
            if self.visuals and hidden:  # a speck inside it, as for a transparent wall
                visual = p.createVisualShape(
                    p.GEOM_SPHERE,
                    radius=HIDDEN_VISUAL,
                    rgbaColor=obj.rgba,
                    visualFramePosition=centres[0],
                    physicsClientId=c,
                )
            elif self.visuals:
                visual = p.createVisualShapeArray(
                    [p.GEOM_BOX] * count,
                    halfExtents=halves,
                    visualFramePositions=centres,
                    visualFrameOrientations=turns,
                    rgbaColors=cls.part_colours(obj) or [obj.rgba] * count,
                    physicsClientId=c,
                )
        elif mesh:
            vertices, indices = mesh
            collision = p.createCollisionShape(p.GEOM_MESH, vertices=vertices, physicsClientId=c)
            if self.visuals:
                visual = p.createVisualShape(
                    p.GEOM_MESH, vertices=vertices, indices=indices, rgbaColor=obj.rgba, physicsClientId=c
                )
        else:
            return self._shape(obj)
        self._shapes[key] = (collision, visual)
        return self._shapes[key]

    def _build_object(self, obj: ObjectSpec) -> int:
        c = self.client
        collision, visual = self._kind_shape(obj) if kind_class(obj.kind) else self._shape(obj)
        orientation = p.getQuaternionFromEuler((0, 0, obj.yaw))
        moving = behaviour_class(obj)
        position = (*obj.position[:2], HIDDEN_Z) if moving and moving.starts_hidden else obj.position
        # Static bodies in maximal coordinates: plain rigid bodies, about twice as fast to create.
        body = p.createMultiBody(
            obj.mass,
            collision,
            visual,
            basePosition=position,
            baseOrientation=orientation,
            useMaximalCoordinates=obj.mass == 0,
            physicsClientId=c,
        )
        self._register(body, obj.kind)
        if obj.kind == "plank":
            p.changeDynamics(body, -1, lateralFriction=PLANK_FRICTION, physicsClientId=c)
        self.objects[body] = obj
        if obj.is_edible:  # food, and bad food: eaten on contact (aaai.task.rewards)
            self.food[body] = obj
        if moving:
            part = moving(obj)
            part.start(self, body)
            if moving.runs:
                self.running[body] = part
        return body

    # --- what behaviours ask of the world -------------------------------------------
    def place(self, body: int, position, yaw: float | None) -> None:
        """Puts a body at ``position``, turned to ``yaw`` about z (None: unturned)."""
        orientation = (0, 0, 0, 1) if yaw is None else p.getQuaternionFromEuler((0, 0, yaw))
        p.resetBasePositionAndOrientation(body, position, orientation, physicsClientId=self.client)

    def pin(self, body: int, points) -> None:
        """Pins a body to the world at two points: a hinge about the line through them."""
        obj = self.objects[body]
        c, s = math.cos(obj.yaw), math.sin(obj.yaw)
        for point in points:
            dx, dy, dz = (point[i] - obj.position[i] for i in range(3))
            local = (c * dx + s * dy, -s * dx + c * dy, dz)  # the point in the body's frame
            p.createConstraint(
                body, -1, -1, -1, p.JOINT_POINT2POINT, (0, 0, 0), local, tuple(point), physicsClientId=self.client
            )

    def door_closed(self, door: Door, body: int) -> None:
        self.closed.append(door)
        self.closed_bodies.append(body)
        self._eaten = None

    @property
    def doors(self) -> dict[int, Door]:
        """The doors still open."""
        return {body: part for body, part in self.running.items() if isinstance(part, Door)}

    @property
    def movers(self) -> dict[int, Behaviour]:
        """The moving parts other than open doors that still have work left."""
        return {body: part for body, part in self.running.items() if not isinstance(part, Door)}

    # --- running --------------------------------------------------------------------
    def eat(self, eaten: dict[int, tuple[ObjectSpec, bool]]) -> None:
        """Takes the eaten yellow pieces (body -> (food, by the head)) out of the world; a green
        one ends the episode and stays."""
        for body, (food, _) in eaten.items():
            if food.kind not in ENDING_KINDS:
                self.remove(body)

    def object_poses(self) -> tuple[list[Pose | None], set[int]]:
        """Where every object of the spec is now, by its index (None once taken out), and the
        indices of the doors that have risen."""
        poses: list[Pose | None] = [None] * len(self.spec.objects)
        for body, i in self.index.items():
            if body in self.objects:
                position, orientation = p.getBasePositionAndOrientation(body, physicsClientId=self.client)
                x, y, z = (float(v) for v in position)
                poses[i] = Pose(x, y, z, float(p.getEulerFromQuaternion(orientation)[2]))
        return poses, {self.index[body] for body in self.closed_bodies}

    def food_positions(self) -> list[tuple[float, float, float]]:
        """Where each piece of food still in the world is now."""
        return [
            p.getBasePositionAndOrientation(body, physicsClientId=self.client)[0]
            for body, obj in self.food.items()
            if obj.is_food
        ]

    def remove(self, body: int) -> None:
        """Takes an object (an eaten food piece) out of the world."""
        p.removeBody(body, physicsClientId=self.client)
        self.kind_index[body] = NO_KIND
        self.objects.pop(body, None)
        self.food.pop(body, None)
        self.running.pop(body, None)
        self._eaten = None

    def advance(self, dt: float, head: tuple[float, float] | None = None) -> None:
        """Moves the moving parts by dt of simulated time. ``head`` (x, y) is needed while any
        door is open."""
        self.time += dt
        done = [body for body, part in self.running.items() if part.advance(self, body, dt, head)]
        for body in done:
            del self.running[body]

    def all_eaten(self) -> bool:
        """Is no food left that the agent can still get to, in a level that had some? (Food shut
        out of the sector the agent is in, L9's behind a closed door, cannot be got to.) The answer
        changes only when food is eaten or a door closes, so it is worked out only then."""
        if self._eaten is None:
            self._eaten = self.had_food and not any(
                all(
                    door.entered(*p.getBasePositionAndOrientation(body, physicsClientId=self.client)[0][:2])
                    for door in self.closed
                )
                for body, obj in self.food.items()
                if obj.is_food
            )
            if self.all_end and not self._eaten:  # every piece of a multi_food kind is eaten
                left = {obj.kind for obj in self.food.values()}
                self._eaten = any(kind not in left for kind in self.all_end)
        return self._eaten

    def ground_height(self, x: float, y: float) -> float:
        """The top of the highest static box the floor holds up at (x, y) (on the floor, or stacked on such
        a box), or 0 (the floor): where a body spawned there stands (a start on a ledge or a raised floor,
        aaai.levels.validate.surface_heights). A box whose bottom lies above what is under it (a bar
        overhead) does not lift it."""
        under = []
        for obj in self.spec.objects:
            cls = kind_class(obj.kind)
            if obj.kind not in SOLID_KINDS or obj.mass or obj.behaviour or obj.shape != "box":
                continue
            if cls is not None and (cls.walkable or cls.parts(obj)):  # a ramp, a kind built of parts
                continue
            c, s = math.cos(obj.yaw), math.sin(obj.yaw)
            dx, dy = x - obj.position[0], y - obj.position[1]
            if abs(c * dx + s * dy) <= obj.size[0] / 2 and abs(-s * dx + c * dy) <= obj.size[1] / 2:
                under.append((obj.position[2] - obj.size[2] / 2, obj.position[2] + obj.size[2] / 2))
        top = 0.0
        for bottom, height in sorted(under):  # lowest first: a box stacked on one that stands counts
            if bottom <= top + 1e-6:
                top = max(top, height)
        return top

    def stand(self, body: int) -> None:
        """Raises a body just loaded at the start by the ground's height there (a start on a ledge)."""
        position, orientation = p.getBasePositionAndOrientation(body, physicsClientId=self.client)
        height = self.ground_height(position[0], position[1])
        if height > 0:
            lifted = (position[0], position[1], position[2] + height)
            p.resetBasePositionAndOrientation(body, lifted, orientation, physicsClientId=self.client)

    def blocked(self, x: float, y: float, radius: float) -> bool:
        """Would a disc at (x, y) leave the arena or overlap a static solid's footprint?"""
        return self.bounds.blocked(x, y, radius)
