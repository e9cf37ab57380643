"""The moving parts an object can have: one class per behaviour, registered once by its name.

An object's ``behaviour`` is a plain dict, ``{"type": name, **fields}``. Each class here says, for
its name: the fields it needs (checked by aaai.levels.validate), how the walking region treats it, where a
piece of food with it will be, how the viewer marks it, and how it runs in the world (built
hidden or pinned, then advanced by simulated time until it is done). The world does the PyBullet
calls; this module holds no simulator state of its own beyond each part's progress.

- random_walk {"speed"}: wanders at speed, turning back at walls (L1 food);
- sink {"depth", "duration"}: moves straight down by depth over duration seconds (the L2b pillar
  and the food on it);
- slide {"to": [x, y], "speed"}: moves in a straight line to (x, y), then stops (L8 food);
- bounce {"speed", "heading"}: moves in a straight line from heading (radians), bouncing off the
  arena's edge and the faces of static solids that stand higher than it, going over lower ones and
  falling off their edges (Animal-AI's bouncing goals);
- door {"direction": [ux, uy], "distance"}: hidden below the arena until the agent's head is
  farther than distance along direction and inside that 90-degree sector, then stands at its
  position for good (L9 sector openings);
- hinge {"pivot": [[x, y, z], [x, y, z]]}: pinned to the world at these two points, so it can only
  turn about the line through them (the L10 plank tips over its trench-side edge and lands across
  the trench).
"""

from __future__ import annotations

import math
from typing import ClassVar

RANDOM_WALK_TURN = 2.0  # heading noise of a random walk, rad per sqrt(s)
PATH_STEP = 0.02  # s: a bouncing piece's path (Bounce.path) is worked out in steps this long (the world's, by default)
PATH_EVERY = 0.5  # s: ... and kept every this long (1.5 units at Animal-AI's bouncing speed here, 3 units/s)
STEP_OVER = 0.05  # units: a bouncing piece goes over a top at most this far above its lowest point
FLOAT_ROOM = 1e-6  # units: a bouncing piece this close above the ground rests on it
FALL_ACCELERATION = 9.81  # units/s/s: a bouncing piece falls off an edge as under the default physics' gravity

REGISTRY: dict[str, type["Behaviour"]] = {}


def register(cls: type["Behaviour"]) -> type["Behaviour"]:
    """Adds a behaviour class under its ``name``: the one place a behaviour is made known."""
    REGISTRY[cls.name] = cls
    return cls


def names() -> tuple[str, ...]:
    return tuple(REGISTRY)


def behaviour_class(obj) -> type["Behaviour"] | None:
    """The class of an object's behaviour (None for an object without one)."""
    return REGISTRY[obj.behaviour["type"]] if obj.behaviour else None


class Behaviour:
    """A moving part. Subclasses set the class attributes and override the hooks they need."""

    name: ClassVar[str] = ""
    fields: ClassVar[tuple[str, ...]] = ()  # the behaviour dict's keys besides "type"
    passable: ClassVar[bool] = False  # the walking region goes through it (validate)
    starts_hidden: ClassVar[bool] = False  # built out of sight and reach, below the arena
    runs: ClassVar[bool] = True  # advanced every step until it is done
    marked: ClassVar[bool] = True  # the viewer rings it as a moving part

    def __init__(self, obj):
        self.obj = obj

    @staticmethod
    def places(obj) -> list[tuple[float, float, float]]:
        """Where the object will be besides its start (validate asks this of food)."""
        return []

    @staticmethod
    def heading_to(obj) -> tuple[float, float] | None:
        """Where the part is heading, for the viewer's arrow (None: nowhere in particular)."""
        return None

    @classmethod
    def path(cls, obj, bounds, seconds: float) -> list[tuple[float, float, float]]:
        """Where a part that never comes to rest will be over its first ``seconds``, sampled, moved
        within ``bounds`` (a spec's :class:`aaai.sim.geometry.Bounds`; validate counts food on such a
        path reachable where any place of it is; empty: not such a part)."""
        return []

    def start(self, world, body: int) -> None:
        """Called once the body is in the world."""

    def advance(self, world, body: int, dt: float, head: tuple[float, float] | None) -> bool:
        """Moves the part by ``dt`` of simulated time; True once it has nothing left to do."""
        return True


@register
class RandomWalk(Behaviour):
    name = "random_walk"
    fields = ("speed",)

    def start(self, world, body: int) -> None:
        self.state = [*self.obj.position, float(world.motion_rng.uniform(-math.pi, math.pi))]  # x, y, z, heading

    def advance(self, world, body: int, dt: float, head) -> bool:
        x, y, z, heading = self.state
        heading += RANDOM_WALK_TURN * math.sqrt(dt) * float(world.motion_rng.standard_normal())
        step = self.obj.behaviour["speed"] * dt
        nx, ny = x + step * math.cos(heading), y + step * math.sin(heading)
        if world.blocked(nx, ny, self.obj.size[0] / 2):
            heading += math.pi  # turn back; stay put this step
            nx, ny = x, y
        self.state[:] = [nx, ny, z, heading]
        world.place(body, (nx, ny, z), None)
        return False


@register
class Bounce(Behaviour):
    """Moves at a constant speed along the ground in a straight line, reflected off the faces of what
    stands higher than its lowest point; it goes over what does not, and falls (at FALL_ACCELERATION)
    onto what lies beneath it, as Animal-AI's bouncing goals roll off a platform's edge."""

    name = "bounce"
    fields = ("speed", "heading")

    def start(self, world, body: int) -> None:
        self.state = self.first(self.obj)

    @staticmethod
    def first(obj) -> list[float]:
        """Its state at the start: x, y, z, its direction (ux, uy) and its upward speed."""
        heading = float(obj.behaviour["heading"])
        return [*map(float, obj.position), math.cos(heading), math.sin(heading), 0.0]

    @staticmethod
    def step(state: list[float], speed: float, dt: float, radius: float, bounds) -> None:
        """Moves ``state`` (x, y, z, ux, uy, vz) by ``dt`` seconds at ``speed``: on, or reflected off
        the face it runs into, or back where that is blocked too; where every way is blocked it stays
        put. On the ground a face is what stands more than STEP_OVER above its underside (there);
        falling, what stands higher than its centre, and it rolls round what it cuts into below that
        (``bounds.push_out``). Then it steps up onto, or falls towards, the ground there. ``bounds``
        is a :class:`aaai.sim.geometry.Bounds`, the world's or a spec's (one rule for both)."""
        x, y, z, ux, uy, vz = state
        step, bottom = speed * dt, z - radius
        falling = vz != 0 or bounds.ground(x, y, bottom) < bottom - FLOAT_ROOM
        height = z if falling else bottom + STEP_OVER
        nx, ny = x + step * ux, y + step * uy
        normal = bounds.face(nx, ny, z, radius, height)
        if normal is not None:
            along = ux * normal[0] + uy * normal[1]
            if along < 0:
                ux, uy = ux - 2 * along * normal[0], uy - 2 * along * normal[1]
            for dx, dy in ((ux, uy), (-ux, -uy)):
                nx, ny = x + step * dx, y + step * dy
                if bounds.face(nx, ny, z, radius, height) is None:
                    ux, uy = dx, dy
                    break
            else:
                nx, ny = x, y
        ground = bounds.ground(nx, ny, bottom)
        if not falling and ground >= bottom - FLOAT_ROOM:
            state[:] = [nx, ny, max(z, ground + radius), ux, uy, 0.0]
            return
        vz -= FALL_ACCELERATION * dt
        nx, ny, z = bounds.push_out(nx, ny, z + vz * dt, radius)
        ground = bounds.ground(nx, ny, z - radius)
        if z <= ground + radius:
            z, vz = ground + radius, 0.0
        state[:] = [nx, ny, z, ux, uy, vz]

    @classmethod
    def path(cls, obj, bounds, seconds: float, every: float = PATH_EVERY) -> list[tuple[float, float, float]]:
        """Where the piece is every ``every`` seconds of its first ``seconds`` (after its start), moved
        as :meth:`advance` moves it, within ``bounds`` (the spec's :class:`aaai.sim.geometry.Bounds`,
        as the world's), in steps of PATH_STEP seconds: the world's steps with the default physics
        (timestep 0.01 s, action_repeat 2); with others a reflection comes up to a step earlier or
        later there."""
        state = cls.first(obj)
        speed, radius = float(obj.behaviour["speed"]), obj.size[0] / 2
        places, per = [], max(1, round(every / PATH_STEP))
        for index in range(1, int(seconds / PATH_STEP) + 1):
            cls.step(state, speed, PATH_STEP, radius, bounds)
            if index % per == 0:
                places.append((state[0], state[1], state[2]))
        return places

    def advance(self, world, body: int, dt: float, head) -> bool:
        before = self.state[:3]
        self.step(self.state, self.obj.behaviour["speed"], dt, self.obj.size[0] / 2, world.bounds)
        if self.state[:3] != before:
            world.place(body, tuple(self.state[:3]), None)
        return False


@register
class Sink(Behaviour):
    """Moves a body straight down by ``depth`` over ``duration`` simulated seconds."""

    name = "sink"
    fields = ("depth", "duration")
    passable = True  # a sinking pillar ends flush with the floor

    def advance(self, world, body: int, dt: float, head) -> bool:
        depth, duration = self.obj.behaviour["depth"], self.obj.behaviour["duration"]
        done = world.time >= duration
        fraction = 1.0 if done else world.time / duration
        x, y, z = self.obj.position
        world.place(body, (x, y, z - depth * fraction), self.obj.yaw)
        return done


@register
class Slide(Behaviour):
    """Moves a body in a straight line to a target at a constant speed, then stops."""

    name = "slide"
    fields = ("to", "speed")

    def __init__(self, obj):
        super().__init__(obj)
        self.x, self.y, self.z = obj.position

    @staticmethod
    def places(obj) -> list[tuple[float, float, float]]:
        return [(*obj.behaviour["to"], obj.position[2])]

    @staticmethod
    def heading_to(obj) -> tuple[float, float] | None:
        return tuple(obj.behaviour["to"][:2]) if "to" in obj.behaviour else None

    def advance(self, world, body: int, dt: float, head) -> bool:
        target = tuple(self.obj.behaviour["to"])
        dx, dy = target[0] - self.x, target[1] - self.y
        remaining, step = math.hypot(dx, dy), self.obj.behaviour["speed"] * dt
        done = remaining <= step
        if done:
            self.x, self.y = target
        else:
            self.x, self.y = self.x + dx / remaining * step, self.y + dy / remaining * step
        world.place(body, (self.x, self.y, self.z), self.obj.yaw)
        return done


@register
class Door(Behaviour):
    """A wall hidden until the agent's head is past ``distance`` along ``direction`` and inside that
    direction's 90-degree sector; then it stands at its place for good."""

    name = "door"
    fields = ("direction", "distance")
    passable = True  # open until the agent has gone through it
    starts_hidden = True
    marked = False

    def entered(self, head_x: float, head_y: float) -> bool:
        ux, uy = self.obj.behaviour["direction"]
        along = head_x * ux + head_y * uy
        across = abs(head_y * ux - head_x * uy)
        return along > self.obj.behaviour["distance"] and across < along

    def advance(self, world, body: int, dt: float, head) -> bool:
        if head is None or not self.entered(head[0], head[1]):
            return False
        world.place(body, self.obj.position, self.obj.yaw)
        world.door_closed(self, body)
        return True


@register
class Hinge(Behaviour):
    name = "hinge"
    fields = ("pivot",)
    runs = False  # the physics turns it
    marked = True

    def start(self, world, body: int) -> None:
        world.pin(body, self.obj.behaviour["pivot"])
