"""The kinds of object in a level: one list, used by the builder, rays, rewards and viewer.

The nine classic kinds (``KINDS``) are the rays' classic channels, in this order. Every newer kind
is a plug-in: one ``Kind`` subclass, registered once with ``@register``, that says its colour, the
classic channel it is seen on with ``sensors.ray_kinds: classic`` (and whether it has a channel of
its own with ``all``), how it is built (one shape, boxes, or a mesh), what touching it does (eaten
for a reward, a fall, a cost per step), how ``aaai.levels.validate`` treats it, how the viewer marks it and
how the head camera draws it. Its fields are the object's own (shape, size, mass): each class
checks them in ``problems``.
"""

from __future__ import annotations

import math
from typing import ClassVar

KINDS = (
    "food_green",  # eaten on contact; ends the episode
    "food_yellow",  # eaten on contact; disappears, the episode goes on
    "wall",
    "transparent_wall",
    "floor",
    "deadly_floor",  # ends the episode with -1
    "plank",  # pushable
    "pillar",
    "hole",  # seen by rays only: the edge of missing floor (a hole, pit or trench) in a ray's direction
)
CLASSIC_KINDS = KINDS  # the rays' channels with sensors.ray_kinds: classic
RAY_ONLY_KINDS = ("hole",)
SOLID_CLASSIC = ("wall", "transparent_wall", "plank", "pillar")

# Kinds the head camera does not draw with sensors.camera_look: task: a transparent wall is solid
# for the body and the rays but lets the camera see through it.
CAMERA_HIDDEN = frozenset({"transparent_wall"})

# Default RGBA per kind (transparent walls are drawn see-through).
COLOURS = {
    "food_green": (0.1, 0.8, 0.1, 1.0),
    "food_yellow": (0.95, 0.8, 0.1, 1.0),
    "wall": (0.55, 0.55, 0.6, 1.0),
    "transparent_wall": (0.7, 0.85, 1.0, 0.3),
    "floor": (0.8, 0.75, 0.65, 1.0),
    "deadly_floor": (0.8, 0.1, 0.1, 1.0),
    "plank": (0.55, 0.35, 0.15, 1.0),
    "pillar": (0.4, 0.4, 0.45, 1.0),
    "hole": (0.15, 0.1, 0.1, 1.0),
}

ZONE_THICKNESS = 0.02  # a floor area is a slab this thick on the floor: the feet stand on it
HOT_ZONE_FACTOR = 10.0  # inside a hot zone the step term is this many times as large (Animal-AI's HotZone)

Part = tuple[tuple[float, float, float], tuple[float, float, float], float]  # centre, full size, roll (body frame)

REGISTRY: dict[str, type["Kind"]] = {}


# --- the tables every module reads -------------------------------------------------------
def _refresh() -> None:
    """The tables derived from the classic kinds and the registry."""
    global ALL_KINDS, KIND_INDEX, OBJECT_KINDS, FOOD_KINDS, EDIBLE_KINDS, SOLID_KINDS, ENDING_KINDS, CAMERA_HIDDEN
    ALL_KINDS = KINDS + tuple(REGISTRY)
    KIND_INDEX = {kind: index for index, kind in enumerate(ALL_KINDS)}
    OBJECT_KINDS = tuple(kind for kind in ALL_KINDS if kind not in RAY_ONLY_KINDS)
    FOOD_KINDS = ("food_green", "food_yellow") + tuple(k for k, c in REGISTRY.items() if c.good)
    EDIBLE_KINDS = FOOD_KINDS + tuple(k for k, c in REGISTRY.items() if c.edible and not c.good)
    SOLID_KINDS = SOLID_CLASSIC + tuple(k for k, c in REGISTRY.items() if c.solid)
    ENDING_KINDS = ("food_green",) + tuple(k for k, c in REGISTRY.items() if c.edible and c.ends)
    CAMERA_HIDDEN = frozenset({"transparent_wall", *(k for k, c in REGISTRY.items() if c.camera_hidden)})


def register(cls: type["Kind"]) -> type["Kind"]:
    """Adds a kind under its ``name``: the one place a kind is made known."""
    if cls.name in KINDS or cls.name in REGISTRY:
        raise ValueError(f"kind {cls.name!r} is registered twice")
    if cls.classic not in KINDS:
        raise ValueError(f"kind {cls.name!r}: classic channel {cls.classic!r} is not one of {', '.join(KINDS)}")
    REGISTRY[cls.name] = cls
    COLOURS[cls.name] = cls.colour
    _refresh()
    return cls


class Kind:
    """A kind of object. Subclasses set the class attributes and override the hooks they need."""

    name: ClassVar[str] = ""
    colour: ClassVar[tuple[float, float, float, float]] = (0.5, 0.5, 0.5, 1.0)
    classic: ClassVar[str] = "wall"  # the classic ray channel it is seen on (sensors.ray_kinds: classic)
    own_channel: ClassVar[bool] = True  # with ray_kinds: all, a channel of its own (else the classic one)
    shape: ClassVar[str] = "box"  # the default shape in an arena file
    shapes: ClassVar[tuple[str, ...]] = ("box",)  # the shapes it may have
    solid: ClassVar[bool] = False  # blocks the body: overlap checks and the walking grid (aaai.levels.validate)
    walkable: ClassVar[bool] = False  # a solid the body walks over (a ramp): not blocked in the walking grid
    zone: ClassVar[bool] = False  # a floor area: a thin slab; rays see it along the ground, as a hole
    deadly: ClassVar[bool] = False  # touching it is a fall onto the deadly floor: -1, the episode ends
    hot: ClassVar[bool] = False  # touching it makes the step term HOT_ZONE_FACTOR times as large
    edible: ClassVar[bool] = False  # eaten on contact (``value`` x size); it is taken out unless ``ends``
    good: ClassVar[bool] = False  # food the agent seeks: it counts for reachability, shaping and the end
    ends: ClassVar[bool] = False  # eating it ends the episode
    any_part: ClassVar[bool] = False  # eaten by any part of the body, whatever agent.limb_food_reward says
    value: ClassVar[float] = 0.0  # reward when eaten, per unit of size (x)
    flat_value: ClassVar[float] = 0.0  # ... when a leg eats it with agent.limb_food_reward: flat
    all_end: ClassVar[bool] = False  # the episode ends once every piece of this kind is eaten
    mark: ClassVar[str] = ""  # the viewer's mark on it: cross, stripes, arrow, rim, dot
    camera: ClassVar[str] = "its colour"  # how the head camera draws it
    camera_hidden: ClassVar[bool] = False  # unseen by the head camera with sensors.camera_look: task
    rule: ClassVar[str] = ""  # one line for people: what it does

    @classmethod
    def problems(cls, obj) -> list[str]:
        """What is wrong with an object of this kind (its shape and size), as messages."""
        if obj.shape not in cls.shapes:
            return [f"a {cls.name} must be a {' or '.join(cls.shapes)}, got {obj.shape!r}"]
        return []

    @classmethod
    def parts(cls, obj) -> list[Part] | None:
        """The boxes it is built of (centre and full size in its own frame, and a roll about its x
        axis), or None for a body of one shape."""
        return None

    @classmethod
    def mesh(cls, obj) -> tuple[list, list] | None:
        """Vertices and triangle indices (own frame) of a convex mesh, or None."""
        return None

    @classmethod
    def part_colours(cls, obj) -> list | None:
        """An RGBA per part (None: the object's colour for every part)."""
        return None

    timed: ClassVar[bool] = False  # its value changes over the episode (TimedFood): it needs ``timing``


# --- food -------------------------------------------------------------------------
@register
class BadFood(Kind):
    name = "bad_food"
    colour = (0.85, 0.05, 0.05, 1.0)
    classic = "deadly_floor"
    shape, shapes = "sphere", ("sphere",)
    edible, ends, any_part = True, True, True
    value, flat_value = -1.0, -1.0
    mark = "cross"
    camera = "a red sphere"
    rule = "touched by any part: -size, the episode ends (Animal-AI's BadGoal)"


@register
class MultiFood(Kind):
    name = "multi_food"
    colour = (1.0, 0.6, 0.0, 1.0)
    classic = "food_yellow"
    shape, shapes = "sphere", ("sphere",)
    edible, good, all_end = True, True, True
    value, flat_value = 1.0, 1.0
    mark = "dot"
    camera = "a gold sphere"
    rule = "eaten: +size, taken out; the episode ends once every multi_food is eaten (GoodGoalMulti)"


@register
class Decoy(Kind):
    name = "decoy"
    colour = (0.55, 0.55, 0.55, 1.0)
    classic = "pillar"
    shape, shapes = "sphere", ("sphere",)
    solid = True
    mark = "dot"
    camera = "a grey sphere"
    rule = "looks like food, is an obstacle: no reward (DecoyGoal)"


# --- food whose value changes over a set time ------------------------------------------
TIMING_KEYS = ("start", "end", "delay", "duration")
MAX_TIMED_VALUE = 100.0  # Animal-AI's 0..5 valence at an import scale up to 20


class TimedFood(Kind):
    """Food whose reward goes from ``timing.start`` to ``timing.end`` in a straight line over
    ``timing.duration`` seconds, after ``timing.delay`` seconds of the episode (Animal-AI's
    RipenGoal, DecayGoal, GrowGoal and ShrinkGoal). Its body keeps one size all episode (a PyBullet
    body cannot be rescaled): the object's ``size``, for growing and shrinking food the importer's
    largest size. Only the reward changes, as a function of the episode's simulated time, so an
    episode stays deterministic and costs nothing more per step. ``value`` is the reward itself,
    not per unit of size."""

    shape, shapes = "sphere", ("sphere",)
    edible, good, any_part = True, True, False
    timed = True
    mark = "clock"
    rising: ClassVar[bool] = True  # the value grows (ripen, grow) or falls (decay, shrink)

    @classmethod
    def value_at(cls, obj, seconds: float) -> float:
        """The reward for eating ``obj`` ``seconds`` into the episode."""
        timing = obj.timing
        start, end = timing["start"], timing["end"]
        done = min(1.0, max(0.0, (seconds - timing["delay"]) / timing["duration"]))
        return start + (end - start) * done

    @classmethod
    def best_value(cls, obj) -> float:
        """Its best value (0 while its timing is malformed: aaai.levels.validate then refuses it)."""
        ends = [obj.timing.get(k) for k in ("start", "end")] if isinstance(obj.timing, dict) else []
        numbers = [v for v in ends if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)]
        return float(max(numbers)) if len(numbers) == 2 else 0.0

    @classmethod
    def problems(cls, obj) -> list[str]:
        problems = super().problems(obj)
        timing = obj.timing
        allowed = (
            f"a mapping with {', '.join(TIMING_KEYS)}: numbers, start and end in 0..{MAX_TIMED_VALUE:g} with "
            f"end {'above' if cls.rising else 'below'} start, delay 0 or more, duration above 0 (seconds)"
        )
        if (
            not isinstance(timing, dict)
            or set(timing) != set(TIMING_KEYS)
            or not all(
                isinstance(timing[k], (int, float)) and not isinstance(timing[k], bool) and math.isfinite(timing[k])
                for k in TIMING_KEYS
            )
        ):
            return problems + [f"a {cls.name}'s timing is {timing!r}; allowed: {allowed}"]
        start, end, delay, duration = (timing[k] for k in TIMING_KEYS)
        if (
            not (0 <= start <= MAX_TIMED_VALUE and 0 <= end <= MAX_TIMED_VALUE)
            or delay < 0
            or duration <= 0
            or (end > start) != cls.rising
            or end == start
        ):
            problems.append(f"a {cls.name}'s timing is {timing!r}; allowed: {allowed}")
        return problems


@register
class RipeningFood(TimedFood):
    name = "ripening_food"
    colour = (0.55, 0.7, 0.3, 1.0)
    classic = "food_yellow"
    camera = "an olive sphere"
    rule = "eaten: the value at that time (start -> end, rising), taken out; the episode goes on (RipenGoal)"


@register
class DecayingFood(TimedFood):
    name = "decaying_food"
    colour = (0.75, 0.55, 0.2, 1.0)
    classic = "food_yellow"
    rising = False
    camera = "an ochre sphere"
    rule = "eaten: the value at that time (start -> end, falling), taken out; the episode goes on (DecayGoal)"


@register
class GrowingFood(TimedFood):
    name = "growing_food"
    colour = (0.2, 0.9, 0.5, 1.0)
    classic = "food_green"
    ends = True
    camera = "a mint-green sphere"
    rule = "eaten: the value at that time (start -> end, rising); the episode ends (GrowGoal)"


@register
class ShrinkingFood(TimedFood):
    name = "shrinking_food"
    colour = (0.1, 0.55, 0.25, 1.0)
    classic = "food_green"
    ends, rising = True, False
    camera = "a dark green sphere"
    rule = "eaten: the value at that time (start -> end, falling); the episode ends (ShrinkGoal)"


# --- floor areas ------------------------------------------------------------------
class Zone(Kind):
    zone = True
    classic = "hole"
    mark = "stripes"

    @classmethod
    def problems(cls, obj) -> list[str]:
        problems = super().problems(obj)
        if abs(obj.position[2] - obj.size[2] / 2) > 1e-3 or obj.size[2] > 0.1:
            problems.append(
                f"a {cls.name} is a slab on the floor: height at most 0.1 (e.g. {ZONE_THICKNESS}) "
                f"and z = height / 2, got z {obj.position[2]:g}, height {obj.size[2]:g}"
            )
        return problems


@register
class HotZone(Zone):
    name = "hot_zone"
    colour = (1.0, 0.5, 0.0, 1.0)
    hot = True
    camera = "an orange floor area"
    rule = f"a floor area: each step any part touches it, the step term is {HOT_ZONE_FACTOR:g} times as large"


@register
class DeathZone(Zone):
    name = "death_zone"
    colour = (0.75, 0.0, 0.0, 1.0)
    deadly = True
    camera = "a dark red floor area"
    rule = "a floor area: touching it is falling onto the deadly floor (-1, the episode ends)"


# --- solids -----------------------------------------------------------------------
@register
class Ramp(Kind):
    """A wedge rising along its own +x from the floor to its full height."""

    name = "ramp"
    colour = (0.8, 0.45, 0.7, 1.0)
    classic = "wall"
    solid = walkable = True
    mark = "arrow"
    camera = "a pink wedge"
    rule = "a wedge the body walks up (rising along its own +x)"

    @classmethod
    def mesh(cls, obj):
        hx, hy, hz = (s / 2 for s in obj.size)
        vertices = [(-hx, -hy, -hz), (hx, -hy, -hz), (hx, hy, -hz), (-hx, hy, -hz), (hx, -hy, hz), (hx, hy, hz)]
        indices = [
            0,
            2,
            1,
            0,
            3,
            2,  # bottom
            1,
            2,
            5,
            1,
            5,
            4,  # the high end
            0,
            1,
            4,
            3,
            5,
            2,  # the sides
            0,
            4,
            5,
            0,
            5,
            3,
        ]  # the slope
        return vertices, indices


TUNNEL_SEGMENTS = 12
TUNNEL_WALL = 1.0


@register
class Tunnel(Kind):
    """An arch: the upper half of a cylinder lying along its own x axis, open at both ends and at
    the floor, ``size`` = (length, outer width, outer height); its wall is TUNNEL_WALL thick."""

    name = "tunnel"
    colour = (0.35, 0.5, 0.75, 1.0)
    classic = "wall"
    solid = True
    mark = "rim"
    camera = "a blue arch"
    rule = "an arch (half a cylinder) the body walks through"

    @classmethod
    def problems(cls, obj) -> list[str]:
        problems = super().problems(obj)
        if min(obj.size[1] / 2, obj.size[2]) <= TUNNEL_WALL * 1.5:
            problems.append(f"a tunnel's width / 2 and height must exceed {TUNNEL_WALL * 1.5:g}, got {obj.size}")
        return problems

    @classmethod
    def parts(cls, obj):
        length, width, height = obj.size
        a, b = width / 2 - TUNNEL_WALL / 2, height - TUNNEL_WALL / 2  # the wall's mid-line, an ellipse
        bottom = -height / 2
        points = [
            (a * math.cos(math.pi * k / TUNNEL_SEGMENTS), b * math.sin(math.pi * k / TUNNEL_SEGMENTS))
            for k in range(TUNNEL_SEGMENTS + 1)
        ]
        parts = []
        for (y0, z0), (y1, z1) in zip(points, points[1:]):
            chord = math.hypot(y1 - y0, z1 - z0)
            roll = math.atan2(z1 - z0, y1 - y0)
            parts.append(
                (
                    (0.0, (y0 + y1) / 2, bottom + (z0 + z1) / 2 + TUNNEL_WALL / 4),
                    (length, chord + TUNNEL_WALL * 0.3, TUNNEL_WALL),
                    roll,
                )
            )
        # feet: the ends of the arch stand on the floor
        for side in (-1, 1):
            parts.append(
                (
                    (0.0, side * (width / 2 - TUNNEL_WALL / 2), bottom + TUNNEL_WALL / 2),
                    (length, TUNNEL_WALL, TUNNEL_WALL),
                    0.0,
                )
            )
        return parts


@register
class TransparentTunnel(Tunnel):
    name = "transparent_tunnel"
    colour = (0.7, 0.85, 1.0, 0.3)
    classic = "transparent_wall"
    camera_hidden = True
    camera = "unseen with camera_look: task (as a transparent wall); a pale blue arch with classic"
    rule = "a tunnel the camera sees through (CylinderTunnelTransparent)"


class Block(Kind):
    """A shape of several boxes seen from above, ``size`` = (x, y, height); arms BLOCK_ARM thick
    (at most a third of the smaller side)."""

    classic = "wall"
    own_channel = False  # a policy treats it as a wall (or, with a mass, as a plank)
    solid = True
    mark = "rim"

    @classmethod
    def arm(cls, obj) -> float:
        return min(1.0, min(obj.size[0], obj.size[1]) / 3)

    @classmethod
    def plan(cls, sx: float, sy: float, t: float) -> list[tuple[float, float, float, float]]:
        """(x, y, x size, y size) of each box seen from above."""
        raise NotImplementedError

    @classmethod
    def parts(cls, obj):
        sx, sy, sz = obj.size
        return [((x, y, 0.0), (w, d, sz), 0.0) for x, y, w, d in cls.plan(sx, sy, cls.arm(obj))]


@register
class LBlock(Block):
    name = "l_block"
    colour = (0.7, 0.55, 0.35, 1.0)
    camera = "a brown L"
    rule = "an L seen from above: an arm along y at -x and a foot along x at -y"

    @classmethod
    def plan(cls, sx, sy, t):
        return [(-sx / 2 + t / 2, t / 2, t, sy - t), (0.0, -sy / 2 + t / 2, sx, t)]


@register
class JBlock(Block):
    name = "j_block"
    colour = (0.65, 0.5, 0.35, 1.0)
    camera = "a brown J"
    rule = "a J seen from above: an arm along y at +x, a foot along x at -y and a short lip at -x"

    @classmethod
    def plan(cls, sx, sy, t):
        lip = max(t, sy / 4)
        return [
            (sx / 2 - t / 2, t / 2, t, sy - t),
            (0.0, -sy / 2 + t / 2, sx, t),
            (-sx / 2 + t / 2, -sy / 2 + t + (lip - t) / 2, t, lip - t),
        ]


@register
class UBlock(Block):
    name = "u_block"
    colour = (0.75, 0.6, 0.4, 1.0)
    camera = "a brown U"
    rule = "a U seen from above, open toward +y"

    @classmethod
    def plan(cls, sx, sy, t):
        return [(-sx / 2 + t / 2, t / 2, t, sy - t), (sx / 2 - t / 2, t / 2, t, sy - t), (0.0, -sy / 2 + t / 2, sx, t)]


@register
class HollowBox(Block):
    name = "hollow_box"
    colour = (0.6, 0.5, 0.4, 1.0)
    camera = "a brown box open at the top"
    rule = "four walls round an empty middle, open at the top"

    @classmethod
    def plan(cls, sx, sy, t):
        return [
            (-sx / 2 + t / 2, 0.0, t, sy - 2 * t),
            (sx / 2 - t / 2, 0.0, t, sy - 2 * t),
            (0.0, -sy / 2 + t / 2, sx, t),
            (0.0, sy / 2 - t / 2, sx, t),
        ]


ALL_KINDS: tuple[str, ...] = ()
KIND_INDEX: dict[str, int] = {}
OBJECT_KINDS: tuple[str, ...] = ()
FOOD_KINDS: tuple[str, ...] = ()
EDIBLE_KINDS: tuple[str, ...] = ()
SOLID_KINDS: tuple[str, ...] = ()
ENDING_KINDS: tuple[str, ...] = ()
_refresh()


def kind_class(kind: str) -> type[Kind] | None:
    """The plug-in class of a newer kind (None for a classic one)."""
    return REGISTRY.get(kind)


def ray_channels(ray_kinds: str) -> tuple[tuple[str, ...], list[int]]:
    """The rays' channel names and, for each kind index (aaai.spec.kinds.ALL_KINDS order), its column.

    classic: the nine classic channels; a newer kind is seen on its ``classic`` one. all: the
    classic channels, then one for each newer kind with ``own_channel``.
    """
    names = list(KINDS)
    column = list(range(len(KINDS)))
    for kind, cls in REGISTRY.items():
        if ray_kinds == "all" and cls.own_channel:
            names.append(kind)
            column.append(len(names) - 1)
        else:
            column.append(KINDS.index(cls.classic))
    return tuple(names), column


def check_kind(kind: str) -> str:
    """An object's kind: one of OBJECT_KINDS (a hole is missing floor tiles, not an object)."""
    if kind not in OBJECT_KINDS:
        raise ValueError(f"object kind {kind!r} is not known; allowed: {', '.join(OBJECT_KINDS)}")
    return kind


# --- sign boards ------------------------------------------------------------------------
SYMBOLS = {  # 5 x 5 pixels, top row first (Animal-AI's SignBoard symbols)
    "tick": ("....#", "...#.", "#.#..", ".#...", "....."),
    "cross": ("#...#", ".#.#.", "..#..", ".#.#.", "#...#"),
    "circle": (".###.", "#...#", "#...#", "#...#", ".###."),
    "letter_a": (".###.", "#...#", "#####", "#...#", "#...#"),
    "left_arrow": ("..#..", ".#...", "#####", ".#...", "..#.."),
    "right_arrow": ("..#..", "...#.", "#####", "...#.", "..#.."),
    "up_arrow": ("..#..", ".###.", "#.#.#", "..#..", "..#.."),
    "down_arrow": ("..#..", "..#..", "#.#.#", ".###.", "..#.."),
    "u_turn_arrow": (".###.", "#...#", "#...#", "#.#.#", "..##."),
}
SYMBOL_COLOUR = (0.05, 0.05, 0.05, 1.0)


class Sign(Kind):
    """A standing board, ``size`` = (thickness, width, height), its symbol in dark squares on both
    faces (its own -x and +x), as a 5 x 5 picture filling the middle of the board."""

    classic = "wall"
    own_channel = False  # the rays see a board; only the camera tells its symbol
    solid = True
    colour = (0.95, 0.95, 0.9, 1.0)
    mark = "symbol"
    symbol: ClassVar[str] = ""

    @classmethod
    def parts(cls, obj):
        thickness, width, height = obj.size
        pixel = min(width, height) * 0.7 / 5
        parts = [((0.0, 0.0, 0.0), (thickness, width, height), 0.0)]
        for row, line in enumerate(SYMBOLS[cls.symbol]):
            for column, cell in enumerate(line):
                if cell == "#":  # seen from -x, the board's +y is on the left
                    parts.append(((0.0, (2 - column) * pixel, (2 - row) * pixel), (thickness + 0.1, pixel, pixel), 0.0))
        return parts

    @classmethod
    def part_colours(cls, obj):
        return [obj.rgba] + [SYMBOL_COLOUR] * (len(cls.parts(obj)) - 1)


for _symbol in SYMBOLS:
    register(
        type(
            f"Sign_{_symbol}",
            (Sign,),
            {
                "name": f"sign_{_symbol}",
                "symbol": _symbol,
                "camera": f"a pale board with a dark {_symbol.replace('_', ' ')}",
                "rule": f"a sign board showing {_symbol.replace('_', ' ')} (SignBoard); a solid",
                "__doc__": f"A sign board showing {_symbol.replace('_', ' ')}.",
            },
        )
    )
