"""One Animal-AI arena (an ``!Arena`` of an ``!ArenaConfig``) as the data of an aaai arena file.

Animal-AI's arena is 40 x 40 with its origin at a corner, y up, for a sphere agent 1 across; ours
is centred, z up, for a body whose walking footprint is 10 across (aaai.levels.validate.FOOTPRINT_RADIUS).
One Animal-AI unit becomes ``scale`` units here (default DEFAULT_SCALE = 5: the arena 200 x 200,
a gap of 2 Animal-AI units the narrowest our body walks through):

- position (x, y, z) -> (scale (x - 20), scale (z - 20)), the object's bottom at scale y;
- size (x, y, z) -> (scale x, scale z, scale y): width, depth, height; a goal's size x is its diameter;
- rotation r (degrees, clockwise seen from above, 0 facing +z) -> yaw -r in radians (the agent and
  a tunnel, whose forward is their own +z: pi/2 - r; a ramp, which rises towards its own -z, see
  RAMP_RISES: -pi/2 - r, as ours rises along its +x);
- ``t`` / ``timeLimit`` (steps) -> time_limit t x SECONDS_PER_STEP x scale seconds, one rule for
  every file (250 steps: 160 s at scale 5, 500: 320 s, 1000: 640 s), at most MAX_TIME (t = 0, no limit: MAX_TIME);
- ``pass_mark`` / ``passMark`` p -> pass_mark: food rewards grow with the scale and the time costs
  do not (a whole episode costs Animal-AI's agent 1, ours 0.5 to 1: LEAST_TIME_COST), so p > 0
  becomes max(scale x p - (scale - 1) / 2, scale x p / 2); -1 <= p <= 0 (the food must pay for the
  time used, less -p: an agent that eats nothing fails) becomes LEAST_TIME_COST x p, which an agent
  that eats nothing reaches only at p = -1, as in Animal-AI; p < -1 (an agent that waits passes
  unless it dies or eats bad food) stays p;
- ``blackouts: [-n]`` (dark and light every n frames) -> blackout {light, dark} of n steps each;
  rising frames f1, f2, ... (dark from f1 to f2, ...) -> blackout {switches: [seconds]}, a frame a step;
- -1 (or a missing value) in a position or rotation -> ``{uniform: [low, high]}``, drawn afresh
  for every episode seed as any arena file's randomisation, with ``on_overlap: redraw``: a random
  place that overlaps an item placed before it is drawn again, up to 20 times, and the item left
  out when none is clear, as Animal-AI's ArenaBuilder places it; a random size is drawn once, here,
  from ``np.random.default_rng([IMPORT_SEED, crc32(file name), arena])`` (a random height would
  move the object's centre, which an arena file cannot express);
- a wall crossing a wall before it (their boxes, each side shrunk to SPAWN_SHRINK, overlap) is left
  out, as Animal-AI's ArenaBuilder does not place it (``extras.animalai.walls_left_out``); walls that
  only touch are both placed;
- colours (0..255) -> colour (0..1); a missing colour: the kind's own;
- the agent starts at least AGENT_MARGIN inside the walls (its body is 10 across); a goal or
  movable block above the floor lands, as it would fall in Animal-AI, on the highest static box
  beneath it or on the floor.

Dispensers and trees become a ``spawner`` and the food they give, appearing at its times
(SPAWNERS); a button a ``button`` and the food a touch of the head gives (aaai.spec.dispensers). An
item with no counterpart here (data zones, ...) is named with its file, arena and index
(``Unmappable``), and that arena is skipped. Bouncing goals bounce (aaai.spec.behaviours.
Bounce) at BOUNCE_SPEED; a cylinder tunnel becomes an arch (aaai.spec.kinds.Tunnel) open at the floor; a
sign board with a preset symbol a ``sign_SYMBOL`` board; goals that ripen, decay, grow or shrink
the timed food of aaai.spec.kinds (see TIMED). Reading the files and writing ours: aaai.tools.animalai.
"""

from __future__ import annotations

import math
import re
import reprlib
from typing import Any, TypeGuard

import numpy as np

from aaai.sim.geometry import corners, footprints_overlap
from aaai.spec import ObjectSpec
from aaai.spec.kinds import ZONE_THICKNESS

DEFAULT_SCALE = 5.0
AAI_ARENA = 40.0
# Seconds per Animal-AI step and unit of scale (0.64 s at scale 5): 250 steps, Animal-AI's usual
# episode, give 160 s, in which our body (3.2 units/s) crosses the 200-unit arena two and a half times.
SECONDS_PER_STEP = 0.128
MAX_TIME = 1000.0  # an arena file's longest time limit (aaai.levels.validate.MAX_TIME_LIMIT): t = 0 (no limit)
BOUNCE_SPEED = 3.0  # units/s of a bouncing goal (aaai.spec.behaviours.Bounce), off in its forward direction
WALL_HEIGHT = 4.0
PLANK_MASS = {"light": 2.0, "heavy": 20.0}  # movable blocks (LightBlock, HeavyBlock)
BLOCK_MASS = 5.0  # movable L, J, U blocks and hollow boxes
AGENT_MARGIN = 6.0  # the agent starts at least this far inside the arena's walls
# Animal-AI's ArenaBuilder places an item only where its box, each side shrunk to SPAWN_SHRINK
# (Prefab.sizeAdjustment), cuts nothing placed before it: walls that touch are both placed, a wall
# that crosses an earlier one is left out. (It also raises every item 0.01, which parts no two walls.)
SPAWN_SHRINK = 0.999
EXACT = 1e-9  # footprints_overlap's gap: closer than this (overlapping at all) counts
WALL_KINDS = ("wall", "transparent_wall")

# Animal-AI name -> (our kind, how it maps): "box" (x, z, y), "forward" (z, x, y: its own +z is
# our +x), "goal" (a sphere), "zone" (a floor slab). Sizes: Animal-AI's range (low, high) per axis.
ITEMS = {
    "Wall": ("wall", "box", ((0.1, 0.1, 0.1), (40, 10, 40))),
    "WallTransparent": ("transparent_wall", "box", ((0.1, 0.1, 0.1), (40, 10, 40))),
    "Ramp": ("ramp", "forward", ((0.5, 0.1, 0.5), (40, 10, 40))),
    "CylinderTunnel": ("tunnel", "forward", ((2.5, 2.5, 2.5), (10, 10, 10))),
    "CylinderTunnelTransparent": ("transparent_tunnel", "forward", ((2.5, 2.5, 2.5), (10, 10, 10))),
    "Cardbox1": ("plank", "box", ((0.5, 0.5, 0.5), (10, 10, 10))),
    "LightBlock": ("plank", "box", ((0.5, 0.5, 0.5), (10, 10, 10))),
    "Cardbox2": ("plank", "box", ((0.5, 0.5, 0.5), (10, 10, 10))),
    "HeavyBlock": ("plank", "box", ((0.5, 0.5, 0.5), (10, 10, 10))),
    "UObject": ("u_block", "box", ((1, 0.3, 3), (5, 2, 20))),
    "UBlock": ("u_block", "box", ((1, 0.3, 3), (5, 2, 20))),
    "LObject": ("l_block", "box", ((1, 0.3, 3), (5, 2, 20))),
    "LBlock": ("l_block", "box", ((1, 0.3, 3), (5, 2, 20))),
    "LObject2": ("j_block", "box", ((1, 0.3, 3), (5, 2, 20))),
    "JBlock": ("j_block", "box", ((1, 0.3, 3), (5, 2, 20))),
    "HollowBox": ("hollow_box", "box", ((0.5, 0.5, 0.5), (5, 5, 5))),
    "GoodGoal": ("food_green", "goal", ((0.5,) * 3, (5,) * 3)),
    "GoodGoalBounce": ("food_green", "goal", ((0.5,) * 3, (5,) * 3)),
    "GoodGoalMulti": ("multi_food", "goal", ((0.5,) * 3, (5,) * 3)),
    "GoodGoalMultiBounce": ("multi_food", "goal", ((0.5,) * 3, (5,) * 3)),
    "BadGoal": ("bad_food", "goal", ((0.5,) * 3, (5,) * 3)),
    "BadGoalBounce": ("bad_food", "goal", ((0.5,) * 3, (5,) * 3)),
    "DecoyGoal": ("decoy", "goal", ((0.5,) * 3, (5,) * 3)),
    "DeathZone": ("death_zone", "zone", ((1, 0.5, 1), (40, 10, 40))),
    "HotZone": ("hot_zone", "zone", ((1, 0.5, 1), (40, 10, 40))),
}
# Goals whose value changes (aaai.spec.kinds.TimedFood): name -> (our kind, default delay in frames).
# initialValues / finalValues (valence, 0..5) -> timing start / end x scale (a green of diameter d
# pays d x scale here); delays (frames) and |final - initial| / |changeRates| (frames) -> delay and
# duration, a frame counted as a step (SECONDS_PER_STEP x scale seconds), as blackouts are. The body
# is a sphere of the larger value's size (Animal-AI's sizes are ignored for these, as there).
TIMED = {
    "RipenGoal": ("ripening_food", 150),
    "AntiDecayGoal": ("ripening_food", 150),
    "DecayGoal": ("decaying_food", 150),
    "GrowGoal": ("growing_food", 0),
    "ShrinkGoal": ("shrinking_food", 0),
    "DecayGoalBounce": ("decaying_food", 150),
    "RipenGoalBounce": ("ripening_food", 150),
}
CHANGE_RATE = 0.005  # valence per frame when a file gives no changeRates
HEAVY = ("Cardbox2", "HeavyBlock")
SIGNS = ("SignBoard", "SignPosterboard")
SIGN_SIZE = 1.4  # Animal-AI's sign boards are this big, whatever the file says
MOVABLE_BLOCKS = ("UObject", "UBlock", "LObject", "LBlock", "LObject2", "JBlock", "HollowBox")
# Dispensers (aaai.spec.dispensers): name -> (body size x, y, z in Animal-AI units, food kind, default
# seconds before the first piece, default seconds between pieces). Animal-AI's times are in its
# seconds; one counts as AAI_STEPS_PER_SECOND steps (ML-Agents' default decision period, 5 frames of
# Unity's 0.02 s), a step as SECONDS_PER_STEP x scale seconds here, as for every other time.
SPAWNERS = {
    "SpawnerTree": ((5.19, 5.95, 5.02), "multi_food", 6.0, 4.0),  # first after ripenTimes (6 s), then every 4 s
    "SpawnerDispenser": ((1.67, 4.46, 1.67), "multi_food", 10.0, 1.5),  # after doorDelays (10 s), every 1.5 s
    "SpawnerDispenserTall": ((1.67, 4.46, 1.67), "multi_food", 10.0, 1.5),
    "SpawnerDispenserShort": ((1.67, 1.67, 1.67), "multi_food", 10.0, 1.5),
    "SpawnerContainer": ((1.67, 1.67, 1.67), "multi_food", 10.0, 1.5),
    "SpawnerContainerShort": ((1.67, 1.67, 1.67), "multi_food", 10.0, 1.5),
}
BUTTONS = ("SpawnerButton", "Pillar-Button")
BUTTON_SIZE = 1.3  # Animal-AI's button, whatever the file says
BUTTON_FOOD = {"GoodGoal": "food_green", "BadGoal": "bad_food", "GoodGoalMulti": "multi_food"}
AAI_STEPS_PER_SECOND = 10.0
MAX_SPAWNED = 5  # pieces a dispenser gives here when Animal-AI's spawnCounts is -1 (without end)
SPAWNED_SIZE = 1.0  # Animal-AI units: a dispensed piece's diameter (finalValues when given)
NOT_HERE = {  # known Animal-AI items without a counterpart, and why
    "DataZone": "data zones are not built here",
    "Datazone": "data zones are not built here",
    "BadGoalMulti": "non-ending bad food is not built here",
}

# The Animal-AI Olympics' ten categories (Crosby et al. 2020), by the number a competition file's
# name begins with; the scoreboard's summary groups the imported arenas by them.
CATEGORIES = {
    "01": "food retrieval",
    "02": "preferences",
    "03": "obstacles",
    "04": "avoidance",
    "05": "spatial reasoning",
    "06": "robustness",
    "07": "internal models",
    "08": "object permanence",
    "09": "advanced preferences",
    "10": "causal reasoning",
}
# Which way a ramp rises is not in Animal-AI's documents; the competition files say it. Of their
# arenas with food on a platform, 22 have a ramp whose high end meets the platform's top if ramps
# rise towards their own -z, and only 6 (which meet it either way) if they rise towards +z.
RAMP_RISES = "-z"
FLOOR_HEIGHT = 1.0  # Animal-AI units: a wall at most this high over the whole arena is its floor
ZONES = ("death_zone", "hot_zone")
MAX_OBJECTS = 500  # objects in one arena (Animal-AI's own arenas hold a few dozen)
_SHOWN = reprlib.Repr()
_SHOWN.maxlevel, _SHOWN.maxstring, _SHOWN.maxother, _SHOWN.maxlist, _SHOWN.maxdict = 3, 60, 60, 6, 6


# The least a whole episode's time costs our agent (aaai.task.rewards: the step term, -0.5/T a step;
# the head on the floor doubles it), against Animal-AI's 1 (-1/T a step).
LEAST_TIME_COST = 0.5


def pass_mark(mark: float, scale: float) -> float:
    """Animal-AI's pass mark ``mark`` as ours at ``scale`` (the module's rule): food pays ``scale``
    times as much here, time costs the same or less, so an agent that eats nothing passes here where it
    passes there (``mark`` <= -1) and fails where it fails there (-1 < ``mark`` <= 0)."""
    if mark > 0:
        return max(scale * mark - (scale - 1) / 2, scale * mark / 2)
    if mark >= -1:
        return LEAST_TIME_COST * mark
    return float(mark)


def shown(value: object) -> str:
    """A value from the file as a message shows it: its repr, cut short (an alias can make it huge)."""
    return _SHOWN.repr(value)


def is_number(value: object) -> TypeGuard[float]:
    """A finite int or float (not a bool): what a number in an Animal-AI file must be."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


class Unmappable(Exception):
    """An item or setting with no counterpart here; its arena is skipped."""


def convert_arena(
    source: str, key: object, arena: object, scale: float, rng: np.random.Generator
) -> tuple[dict, list[str]]:
    """The arena ``key`` of the file ``source`` as an aaai arena file's data, with the names of its
    items; random sizes are drawn from ``rng``. Unmappable names what has no counterpart here."""
    return _Arena(source, key, arena, scale, rng).convert()


class _Arena:
    def __init__(self, source: str, key: object, arena: object, scale: float, rng: np.random.Generator):
        self.source, self.key, self.arena, self.scale, self.rng = source, key, arena, scale, rng
        self.half = AAI_ARENA / 2 * scale
        self.walls: list[tuple] = []  # the walls placed so far, as Animal-AI tests a new one (_cuts_a_wall)
        self.left_out: list[dict] = []  # walls Animal-AI's ArenaBuilder would not place

    def where(self, index: int, name: str) -> str:
        return f"{self.source}, arena {self.key}, item {index} ({name if len(name) <= 60 else name[:57] + '...'})"

    # numbers
    def _xy(self, value: object, low: float, high: float) -> float | dict:
        """An Animal-AI horizontal coordinate as ours, or a uniform draw for -1."""
        if not is_number(value) or value == -1:
            return {"uniform": [round(low, 3), round(high, 3)]}
        return round(self.scale * (value - AAI_ARENA / 2), 4)

    def _size(self, value: object, low: float, high: float) -> float:
        if not is_number(value) or value == -1:
            value = float(self.rng.uniform(low, high))
        return round(self.scale * max(float(value), 1e-3), 4)

    @staticmethod
    def _entry(values: object, index: int) -> Any:
        return values[index] if isinstance(values, list) and index < len(values) else None

    def _yaw(self, rotation: object, offset: float = 0.0) -> float | dict:
        if not is_number(rotation) or rotation == -1:
            return {"uniform": [round(-math.pi, 6), round(math.pi, 6)]}
        return round((offset - math.radians(rotation) + math.pi) % (2 * math.pi) - math.pi, 6)

    # the arena
    def convert(self) -> tuple[dict, list[str]]:
        arena = self.arena
        if not isinstance(arena, dict):
            raise Unmappable(f"{self.source}, arena {self.key}: got {shown(arena)}; allowed: an !Arena mapping")
        items = arena.get("items", arena.get("Items", []))
        if not isinstance(items, list):
            raise Unmappable(f"{self.source}, arena {self.key}: items must be a list, got {shown(items)}")
        steps = arena.get("timeLimit", arena.get("t", 0))
        if not is_number(steps) or steps < 0:
            raise Unmappable(
                f"{self.source}, arena {self.key}: t / timeLimit {shown(steps)}; allowed: a number of steps"
            )
        time_limit = MAX_TIME if steps == 0 else min(MAX_TIME, max(1.0, steps * SECONDS_PER_STEP * self.scale))
        out: dict = {
            "description": f"Animal-AI {self.source} arena {self.key}, imported at scale {self.scale:g}",
            "arena_walls": True,
            "arena_size": [2 * self.half, 2 * self.half],
            "wall_height": WALL_HEIGHT,
            "time_limit": round(time_limit, 3),
            "walls_cross": True,  # walls Animal-AI places as touching may overlap by its shrink (_cuts_a_wall)
        }
        found = re.match(r"(\d\d)-", self.source)
        if found and found.group(1) in CATEGORIES:  # a competition file: 04-01-02.yaml is of category 4
            out["extras"] = {"animalai": {"category": f"{found.group(1)} {CATEGORIES[found.group(1)]}"}}
        mark = arena.get("passMark", arena.get("pass_mark"))
        if mark is not None:
            if not is_number(mark):
                raise Unmappable(f"{self.source}, arena {self.key}: pass mark {shown(mark)}; allowed: a number")
            s = self.scale
            out["pass_mark"] = round(pass_mark(mark, s), 4)
            out["reach"] = "pass_mark"  # food out of reach is a lure as long as what can be reached passes
        blackouts = arena.get("blackouts")
        if blackouts:
            frame = SECONDS_PER_STEP * self.scale
            if isinstance(blackouts, list) and len(blackouts) == 1 and is_number(blackouts[0]) and blackouts[0] < 0:
                seconds = -blackouts[0] * frame
                out["blackout"] = {"light": round(seconds, 4), "dark": round(seconds, 4)}
            elif (
                isinstance(blackouts, list)
                and all(is_number(b) and b >= 0 for b in blackouts)
                and all(b > a for a, b in zip(blackouts, blackouts[1:]))
            ):  # the frames at which the light goes off, on, off, ...
                out["blackout"] = {"switches": [round(b * frame, 4) for b in blackouts]}
            else:
                raise Unmappable(
                    f"{self.source}, arena {self.key}: blackouts {shown(blackouts)} cannot be mapped; allowed: "
                    "[-n] (dark and light every n frames) or rising frames at which the light switches"
                )
        total = sum(
            _count(item, f"{self.source}, arena {self.key}, item {index}")
            for index, item in enumerate(items)
            if isinstance(item, dict)
        )
        if total > MAX_OBJECTS:
            raise Unmappable(
                f"{self.source}, arena {self.key}: {total:,} objects; allowed: at most {MAX_OBJECTS} in an arena"
            )
        objects, names, agent = [], [], None
        raised: list = []  # Animal-AI's start (x, y here), when it gives a height
        for index, item in enumerate(items):
            if not isinstance(item, dict) or not isinstance(item.get("name"), str):
                raise Unmappable(
                    f"{self.source}, arena {self.key}, item {index}: got {shown(item)}; allowed: an !Item with a name"
                )
            name = item["name"]
            if name == "Agent":
                agent = self.agent(item)
                start = self._entry(item.get("positions"), 0)
                start = start if isinstance(start, dict) else {}
                raised = [self._xy(start.get(k, -1), 0, 0) for k in ("x", "z")] if is_number(start.get("y")) else []
                continue
            objects += self.item(index, name, item)
            names.append(name)
        if agent is None:
            agent = {
                "x": {"uniform": [-self.half + AGENT_MARGIN, self.half - AGENT_MARGIN]},
                "y": {"uniform": [-self.half + AGENT_MARGIN, self.half - AGENT_MARGIN]},
                "yaw": self._yaw(None),
            }
        out["agent"] = agent
        if self.left_out:  # the import report's changes (aaai.tools.animalai)
            out.setdefault("extras", {}).setdefault("animalai", {})["walls_left_out"] = self.left_out
        objects = self.floors(objects, out)
        supports = _supports(objects)
        if raised and all(isinstance(v, float) for v in raised):  # the agent stands on a static box there
            tops = [
                b["position"][2] + b["size"][2] / 2
                for b in supports
                if _inside(raised[0], raised[1], {"yaw": 0.0, **b})
            ]
            if tops and max(tops) > 0.01:  # the import report's cause (aaai.tools.animalai_causes)
                out.setdefault("extras", {}).setdefault("animalai", {})["start_height"] = round(max(tops), 4)
        ramps = [obj for obj in objects if obj["kind"] == "ramp" and _numbers(obj)]
        settled: dict[int, dict] = {}
        for k in sorted(range(len(objects)), key=lambda k: _bottom(objects[k])):  # lowest first: blocks stack
            settled[k] = _settled(objects[k], supports, ramps)
            if settled[k].get("mass") and settled[k]["kind"] == "plank" and _numbers(settled[k]):
                supports.append(settled[k])  # a movable box (not a U, L or hollow one): what falls on it rests on it
        rolled = []
        for k in range(len(objects)):  # a goal left on a ramp's slope rolls down it, as Animal-AI's goals do
            moved = _rolled(settled[k], supports, ramps, self.half)
            if moved is not settled[k]:
                rolled.append({"from": settled[k]["position"][:2], "to": moved["position"][:2]})
                settled[k] = moved
        if rolled:
            out.setdefault("extras", {}).setdefault("animalai", {})["rolled"] = rolled
        out["objects"] = [settled[k] for k in range(len(objects))]
        for obj in out["objects"]:  # a random place overlapping an item before it is drawn again, as Animal-AI does
            if any(isinstance(v, dict) for v in obj["position"]):
                obj["on_overlap"] = "redraw"
        return out, names

    def floors(self, objects: list[dict], out: dict) -> list[dict]:
        """A low wall on the floor that covers the whole arena (Animal-AI's way of colouring the
        floor) is the floor: taken out, its colour the floor's, and what stood on it lowered by its
        height (a body cannot stand on a wall here)."""
        for obj in objects:
            if obj["kind"] != "wall" or not all(isinstance(v, (int, float)) for v in (*obj["position"], *obj["size"])):
                continue
            x, y, z = obj["position"]
            width, depth, height = obj["size"]
            if (
                abs(z - height / 2) < 1e-6
                and height <= FLOOR_HEIGHT * self.scale
                and min(width, depth) >= 0.95 * 2 * self.half
                and abs(x) + abs(y) < 0.05 * self.half
            ):
                rest = [other for other in objects if other is not obj]
                for other in rest:
                    position = other["position"]
                    if isinstance(position[2], (int, float)):
                        bottom = position[2] - other["size"][2] / 2 if other.get("kind") not in ZONES else 0.0
                        if bottom >= height - 1e-6:
                            other["position"] = [position[0], position[1], round(position[2] - height, 4)]
                if "colour" in obj:
                    out["colours"] = {"floor": obj["colour"]}
                out.setdefault("extras", {}).setdefault("animalai", {})["floor"] = "a wall over the whole floor"
                return rest
        return objects

    def agent(self, item: dict) -> dict:
        position = self._entry(item.get("positions"), 0) or {}
        inside = self.half - AGENT_MARGIN  # our body is 10 across: a start by the wall moves in to clear it

        def coordinate(value: object) -> float | dict:
            mapped = self._xy(value, -inside, inside)
            return mapped if isinstance(mapped, dict) else min(max(mapped, -inside), inside)

        return {
            "x": coordinate(position.get("x", -1)),
            "y": coordinate(position.get("z", -1)),
            "yaw": self._yaw(self._entry(item.get("rotations"), 0), math.pi / 2),
        }

    def signs(self, index: int, name: str, item: dict) -> list[dict]:
        """Sign boards: one of the preset symbols each (aaai.spec.kinds.SYMBOLS); a special symbol (a
        pixel grid of the file's own) cannot be mapped."""
        from aaai.spec.kinds import SYMBOLS

        symbols = item.get("symbolNames") or []
        objects = []
        for k in range(_count(item, self.where(index, name))):
            position = self._entry(item.get("positions"), k)
            symbol = self._entry(symbols, k)
            key = symbol.replace("-", "_") if isinstance(symbol, str) else None
            if key not in SYMBOLS:
                raise Unmappable(
                    f"{self.where(index, name)}: cannot be mapped (symbol {shown(symbol)}; allowed: "
                    f"{', '.join(s.replace('_', '-') for s in SYMBOLS)}); arena skipped"
                )
            position = position if isinstance(position, dict) else {}
            side = SIGN_SIZE * self.scale
            reach = self.half - side
            bottom = position.get("y", 0)
            bottom = self.scale * bottom if is_number(bottom) and bottom > 0 else 0.0
            objects.append(
                {
                    "kind": f"sign_{key}",
                    "position": [
                        self._xy(position.get("x", -1), -reach, reach),
                        self._xy(position.get("z", -1), -reach, reach),
                        round(bottom + side / 2, 4),
                    ],
                    "size": [round(max(0.3, 0.05 * side), 4), side, side],
                    "yaw": self._yaw(self._entry(item.get("rotations"), k), math.pi / 2),
                }
            )
        return objects

    def timed(self, index: int, name: str, item: dict) -> list[dict]:
        """Goals that ripen, decay, grow or shrink: a sphere of the larger value's size whose reward
        moves from the initial to the final value (aaai.spec.kinds.TimedFood)."""
        from aaai.spec.kinds import REGISTRY, TimedFood

        kind, default_delay = TIMED[name]
        where = self.where(index, name)
        objects = []
        for k in range(_count(item, where)):
            values = {}
            for key in ("initialValues", "finalValues", "delays", "changeRates"):
                value = self._entry(item.get(key), k)
                if value is not None and not is_number(value):
                    raise Unmappable(
                        f"{where}: cannot be mapped ({key} {shown(value)}; allowed: numbers); arena skipped"
                    )
                values[key] = value
            start, end = values["initialValues"], values["finalValues"]
            if start is None or end is None:
                raise Unmappable(
                    f"{where}: cannot be mapped (initialValues {start!r}, finalValues {end!r}; allowed: "
                    "both given, 0..5); arena skipped"
                )
            timed = REGISTRY[kind]
            assert issubclass(timed, TimedFood)  # every kind in TIMED is timed food
            rising = timed.rising
            if not (0 <= start <= 5 and 0 <= end <= 5) or start == end or (end > start) != rising:
                raise Unmappable(
                    f"{where}: cannot be mapped (initialValues {start!r}, finalValues {end!r}; allowed: "
                    f"0..5 with the final value {'above' if rising else 'below'} the initial); "
                    "arena skipped"
                )
            delay = values["delays"] if values["delays"] is not None else default_delay
            rate = abs(values["changeRates"]) if values["changeRates"] is not None else CHANGE_RATE
            if delay < 0 or rate <= 0:
                raise Unmappable(
                    f"{where}: cannot be mapped (delays {delay!r}, changeRates {rate!r}; allowed: a delay "
                    "of 0 or more and a non-zero rate); arena skipped"
                )
            frame = SECONDS_PER_STEP * self.scale
            position = self._entry(item.get("positions"), k)
            position = position if isinstance(position, dict) else {}
            diameter = round(max(start, end) * self.scale, 4)
            reach = max(0.0, self.half - diameter / 2 - 1.0)
            bottom = position.get("y", 0)
            bottom = self.scale * bottom if is_number(bottom) and bottom > 0 else 0.0
            obj = {
                "kind": kind,
                "shape": "sphere",
                "position": [
                    self._xy(position.get("x", -1), -reach, reach),
                    self._xy(position.get("z", -1), -reach, reach),
                    round(bottom + diameter / 2, 4),
                ],
                "size": [diameter] * 3,
                "timing": {
                    "start": round(start * self.scale, 4),
                    "end": round(end * self.scale, 4),
                    "delay": round(delay * frame, 4),
                    "duration": round(abs(end - start) / rate * frame, 4),
                },
            }
            if name.endswith("Bounce"):
                obj["behaviour"] = {
                    "type": "bounce",
                    "speed": BOUNCE_SPEED,
                    "heading": self._yaw(self._entry(item.get("rotations"), k), math.pi / 2),
                }
            objects.append(obj)
        return objects

    def seconds(self, aai_seconds: float) -> float:
        """An Animal-AI time (its seconds) in seconds here."""
        return round(aai_seconds * AAI_STEPS_PER_SECOND * SECONDS_PER_STEP * self.scale, 4)

    def dispensers(self, index: int, name: str, item: dict) -> list[dict]:
        """A dispenser or tree: its body (aaai.spec.dispensers.Spawner) and the pieces it gives, in a
        row in front of it, each appearing at its time (behaviour ``release``)."""
        (bx, by, bz), food, first, every = SPAWNERS[name]
        where = self.where(index, name)
        objects = []
        for k in range(_count(item, where)):
            values = {}
            for key in ("spawnCounts", "finalValues", "delays", "doorDelays", "ripenTimes", "timesBetweenSpawns"):
                value = self._entry(item.get(key), k)
                if value is not None and not is_number(value):
                    raise Unmappable(
                        f"{where}: cannot be mapped ({key} {shown(value)}; allowed: numbers); arena skipped"
                    )
                values[key] = value
            count = values["spawnCounts"]
            count = MAX_SPAWNED if count is None or count < 0 else min(int(count), MAX_SPAWNED)
            size = values["finalValues"] if values["finalValues"] and values["finalValues"] > 0 else SPAWNED_SIZE
            wait = values["ripenTimes"] if name == "SpawnerTree" else values["doorDelays"]  # before the first
            start = (values["delays"] or 0) + (wait if wait is not None else first)
            gap = values["timesBetweenSpawns"] if values["timesBetweenSpawns"] else every
            position = self._entry(item.get("positions"), k)
            position = position if isinstance(position, dict) else {}
            rotation = self._entry(item.get("rotations"), k)
            if not all(is_number(position.get(a)) and position.get(a) != -1 for a in "xz"):
                raise Unmappable(
                    f"{where}: cannot be mapped (a dispenser at a random position; allowed: x and z given); "
                    "arena skipped"
                )
            yaw = self._yaw(rotation if is_number(rotation) and rotation != -1 else 0.0, math.pi / 2)  # random: 0
            assert isinstance(yaw, float)
            x, y = self._xy(position["x"], 0, 0), self._xy(position["z"], 0, 0)
            assert isinstance(x, float) and isinstance(y, float)
            objects.append(
                {
                    "kind": "spawner",
                    "position": [x, y, round(by * self.scale / 2, 4)],
                    "size": [round(bz * self.scale, 4), round(bx * self.scale, 4), round(by * self.scale, 4)],
                    "yaw": yaw,
                }
            )
            diameter = round(size * self.scale, 4)
            for n in range(count):  # in a row out from its front, the first nearest
                out = (bz / 2 + 0.5) * self.scale + diameter / 2 + n * (diameter + 0.5 * self.scale)
                objects.append(
                    {
                        "kind": food,
                        "shape": "sphere",
                        "position": [
                            round(x + out * math.cos(yaw), 4),
                            round(y + out * math.sin(yaw), 4),
                            round(diameter / 2, 4),
                        ],
                        "size": [diameter] * 3,
                        "behaviour": {"type": "release", "after": self.seconds(start + n * gap)},
                    }
                )
        return objects

    def buttons(self, index: int, name: str, item: dict) -> list[dict]:
        """A button (aaai.spec.dispensers.Button) and the piece it gives when the head touches it
        (behaviour ``press``): the most likely of ``rewardNames`` (by ``rewardWeights``), of size
        ``spawnedRewardSize``, at ``rewardSpawnPos``."""
        from aaai.agent.urdf_writer import HEAD_RADIUS

        where = self.where(index, name)
        objects = []
        names = item.get("rewardNames") or ["GoodGoal"]
        weights = item.get("rewardWeights") or [1.0] * len(names)
        if (
            not isinstance(names, list)
            or not isinstance(weights, list)
            or len(weights) != len(names)
            or not all(n in BUTTON_FOOD for n in names)
            or not all(is_number(w) and w >= 0 for w in weights)
        ):
            raise Unmappable(
                f"{where}: cannot be mapped (rewardNames {shown(names)}, rewardWeights {shown(weights)}; allowed: "
                f"names from {', '.join(BUTTON_FOOD)} with as many weights, 0 or more); arena skipped"
            )
        food = BUTTON_FOOD[names[max(range(len(names)), key=lambda i: weights[i])]]
        size = item.get("spawnedRewardSize", SPAWNED_SIZE)
        if not is_number(size) or size <= 0:
            raise Unmappable(f"{where}: cannot be mapped (spawnedRewardSize {shown(size)}; allowed: above 0)")
        side = BUTTON_SIZE * self.scale
        reach = self.half - side
        diameter = round(size * self.scale, 4)
        for k in range(_count(item, where)):
            position = self._entry(item.get("positions"), k)
            position = position if isinstance(position, dict) else {}
            x, y = self._xy(position.get("x", -1), -reach, reach), self._xy(position.get("z", -1), -reach, reach)
            if not (isinstance(x, float) and isinstance(y, float)):
                raise Unmappable(
                    f"{where}: cannot be mapped (a button at a random position; allowed: x and z given); arena skipped"
                )
            spot = item.get("rewardSpawnPos")
            spot = self._entry(spot, k) if isinstance(spot, list) else spot
            spot = spot if isinstance(spot, dict) else {}
            food_reach = self.half - diameter / 2 - 1.0
            objects.append({"kind": "button", "shape": "cylinder", "position": [x, y, side / 2], "size": [side] * 3})
            piece: dict = {
                "kind": food,
                "shape": "sphere",
                "position": [
                    self._xy(spot.get("x", -1), -food_reach, food_reach),
                    self._xy(spot.get("z", -1), -food_reach, food_reach),
                    round(diameter / 2, 4),
                ],
                "size": [diameter] * 3,
                "behaviour": {"type": "press", "button": [x, y], "reach": round(side / 2 + HEAD_RADIUS + 0.5, 4)},
            }
            objects.append(piece)
        return objects

    def item(self, index: int, name: str, item: dict) -> list[dict]:
        if name in SPAWNERS:
            return self.dispensers(index, name, item)
        if name in BUTTONS:
            return self.buttons(index, name, item)
        if name in SIGNS:
            return self.signs(index, name, item)
        if name in TIMED:
            return self.timed(index, name, item)
        if name not in ITEMS:
            why = NOT_HERE.get(name, "no such kind here")
            raise Unmappable(f"{self.where(index, name)}: cannot be mapped ({why}); arena skipped")
        kind, form, (low, high) = ITEMS[name]
        objects = []
        for k in range(_count(item, self.where(index, name))):
            position = self._entry(item.get("positions"), k)
            position = position if isinstance(position, dict) else {}
            size = self._entry(item.get("sizes"), k)
            size = size if isinstance(size, dict) else {}
            sx, sy, sz = (self._size(size.get(axis, -1), low[i], high[i]) for i, axis in enumerate("xyz"))
            bottom = position.get("y", 0)
            bottom = self.scale * bottom if is_number(bottom) and bottom > 0 else 0.0
            rotation = self._entry(item.get("rotations"), k)
            obj: dict = {"kind": kind}
            if form == "goal":
                diameter = sx
                obj.update(shape="sphere", size=[diameter] * 3)
                centre_z, footprint = bottom + diameter / 2, diameter / 2
            elif form == "zone":
                obj.update(size=[sx, sz, ZONE_THICKNESS], yaw=self._yaw(rotation))
                centre_z, footprint = ZONE_THICKNESS / 2, math.hypot(sx, sz) / 2
            elif form == "forward":  # its own +z is our +x: length first
                # a ramp rises towards its own -z (RAMP_RISES), so our +x (the way ours rises) is its -z
                offset = -math.pi / 2 if kind == "ramp" else math.pi / 2
                obj.update(size=[sz, sx, sy], yaw=self._yaw(rotation, offset))
                centre_z, footprint = bottom + sy / 2, math.hypot(sx, sz) / 2
            else:
                obj.update(size=[sx, sz, sy], yaw=self._yaw(rotation))
                centre_z, footprint = bottom + sy / 2, math.hypot(sx, sz) / 2
            reach = max(0.0, min(self.half - footprint, self.half - 1.0))
            obj["position"] = [
                self._xy(position.get("x", -1), -reach, reach),
                self._xy(position.get("z", -1), -reach, reach),
                round(centre_z, 4),
            ]
            colour = self._entry(item.get("colors"), k)
            if (
                isinstance(colour, dict)
                and all(is_number(colour.get(c)) and colour[c] >= 0 for c in "rgb")
                and kind in ("wall", "ramp", "tunnel", "plank", "u_block", "l_block", "j_block", "hollow_box")
            ):
                obj["colour"] = [round(min(colour[c], 255) / 255, 4) for c in "rgb"] + [1.0]
            if kind == "plank":
                obj["mass"] = PLANK_MASS["heavy" if name in HEAVY else "light"]
            elif name in MOVABLE_BLOCKS:
                obj["mass"] = BLOCK_MASS
            if name.endswith("Bounce"):
                heading = self._yaw(rotation, math.pi / 2)
                obj["behaviour"] = {"type": "bounce", "speed": BOUNCE_SPEED, "heading": heading}
            if kind in WALL_KINDS and self._cuts_a_wall(obj):
                self.left_out.append({"item": index, "entry": k, "position": obj["position"][:2]})
                continue
            objects.append(
                {
                    key: obj[key]
                    for key in ("kind", "shape", "position", "size", "yaw", "colour", "mass", "behaviour")
                    if key in obj
                }
            )
        return objects

    def _cuts_a_wall(self, wall: dict) -> bool:
        """Whether Animal-AI's ArenaBuilder would leave ``wall`` out: its box, each side SPAWN_SHRINK of
        the size asked for (from its bottom up), cuts a wall placed before it (Physics.OverlapBox at
        the place asked for; there is no second try for a place the file gives). Walls that only touch
        are both placed, as the shrink parts them. A wall placed is remembered for the walls after it.
        Only walls are tested, and only those whose place and turn the file gives."""
        if not _numbers(wall):
            return False
        size = [side * SPAWN_SHRINK for side in wall["size"]]
        bottom = wall["position"][2] - wall["size"][2] / 2
        quad = corners(ObjectSpec(wall["kind"], "box", tuple(wall["position"]), tuple(size), yaw=wall["yaw"]))
        top = bottom + size[2]
        if any(
            low < top and bottom < high and footprints_overlap(other, quad, gap=EXACT)
            for other, low, high in self.walls
        ):
            return True
        self.walls.append((quad, bottom, top))
        return False


def _count(item: dict, where: str) -> int:
    """How many objects an item stands for: its longest list of positions, sizes, rotations or
    colours (Animal-AI draws what a shorter list lacks), at least one."""
    lengths = [1]
    for key in ("positions", "sizes", "rotations", "colors"):
        value = item.get(key)
        if value is not None and not isinstance(value, list):
            raise Unmappable(f"{where}: {key} {shown(value)}; allowed: a list")
        lengths.append(len(value or []))
    return max(lengths)


SUPPORTS = ("wall", "transparent_wall", "plank", "u_block", "l_block", "j_block", "hollow_box")


def _inside(x: float, y: float, box: dict) -> bool:
    """Is (x, y) over an imported box's footprint?"""
    bx, by, _ = box["position"]
    c, s = math.cos(box["yaw"]), math.sin(box["yaw"])
    u, v = c * (x - bx) + s * (y - by), -s * (x - bx) + c * (y - by)
    return abs(u) <= box["size"][0] / 2 and abs(v) <= box["size"][1] / 2


def _bottom(obj: dict) -> float:
    """An object's bottom as given (inf when drawn per seed: settled last, as it is not moved)."""
    z = obj["position"][2]
    return z - obj["size"][2] / 2 if isinstance(z, (int, float)) else math.inf


def _numbers(obj: dict) -> bool:
    """Is every number of an object's place given (none drawn per seed)?"""
    return all(isinstance(v, (int, float)) for v in (*obj["position"], *obj["size"], obj.get("yaw", 0.0)))


def _supports(objects: list[dict]) -> list[dict]:
    """The static boxes of an arena, with every number given, on which a goal or block may land."""
    return [
        box
        for box in objects
        if box["kind"] in SUPPORTS
        and not box.get("mass")
        and all(isinstance(v, (int, float)) for v in (*box["position"], *box["size"], box.get("yaw", 0.0)))
    ]


def _on_slope(goal: dict, ramp: dict) -> float:
    """Where a goal's bottom comes to rest on a ramp's slope at its (x, y): touching the slope, its
    centre above the point of the slope beneath it; 0 when its centre is not over the ramp."""
    from aaai.levels.validate import ramp_clearance
    from aaai.spec import ObjectSpec

    x, y, _ = goal["position"]
    radius = goal["size"][0] / 2
    wedge = ObjectSpec("ramp", "box", tuple(ramp["position"]), tuple(ramp["size"]), ramp.get("yaw", 0.0))
    clear = ramp_clearance(wedge, x, y, radius, radius)  # a piece on the floor there: how far clear of the slope
    return 0.0 if clear is None else max(0.0, -clear)


def _settled(obj: dict, supports: list[dict], ramps: list[dict] | None = None) -> dict:
    """A goal or movable block given above the floor, where Animal-AI would let it fall: onto the
    highest of ``supports`` (static boxes, movable blocks settled before) beneath it, a goal onto the
    slope of one of ``ramps`` beneath it, or the floor (positions drawn at random stay as given)."""
    position = obj["position"]
    if obj["kind"] in SUPPORTS and not obj.get("mass") or not all(isinstance(v, (int, float)) for v in position):
        return obj
    height = obj["size"][2]
    bottom = position[2] - height / 2
    if bottom <= 0:
        return obj
    landing = 0.0
    if obj.get("shape") == "sphere":  # a goal: onto a ramp's slope beneath it (aaai.levels.validate.ramp_clearance)
        landing = max([0.0, *(_on_slope(obj, ramp) for ramp in ramps or () if _on_slope(obj, ramp) <= bottom + 1e-6)])
    for box in supports:
        if box is obj:
            continue
        top = box["position"][2] + box["size"][2] / 2
        if top <= bottom + 1e-6 and _inside(position[0], position[1], {**box, "yaw": box.get("yaw", 0.0)}):
            landing = max(landing, top)
    return {**obj, "position": [position[0], position[1], round(landing + height / 2, 4)]}


ROLL_STEP = 0.25  # units: the step a rolling goal's path is followed in (aaai.tools.animalai_arena._rolled)


def _ground(x: float, y: float, supports: list[dict], wedges: list) -> float:
    """The height of what lies under (x, y): the floor, a static or settled box's top, a ramp's slope
    (``wedges``: the ramps as ObjectSpecs, :func:`aaai.sim.geometry.ramp_height`)."""
    from aaai.sim.geometry import ramp_height

    height = 0.0
    for box in supports:
        if _inside(x, y, {**box, "yaw": box.get("yaw", 0.0)}):
            height = max(height, box["position"][2] + box["size"][2] / 2)
    for wedge in wedges:
        if _inside(x, y, {"position": wedge.position, "size": wedge.size, "yaw": wedge.yaw}):
            height = max(height, wedge.position[2] - wedge.size[2] / 2 + ramp_height(wedge, x, y))
    return height


def _rolled(obj: dict, supports: list[dict], ramps: list[dict], half: float) -> dict:
    """A goal resting on a ramp's slope, where Animal-AI's physics takes it: it rolls down the slope's
    fall line and on in that direction, over tops as high as where it is and off their edges, until
    the ground ahead of it rises or the arena's wall stops it; it rests there (settled onto what lies
    beneath, :func:`_settled`). Any other object is returned as it is (the same object)."""
    if obj.get("shape") != "sphere" or obj.get("behaviour") or obj.get("mass") or not _numbers(obj):
        return obj
    bottom = obj["position"][2] - obj["size"][2] / 2
    under = [r for r in ramps if r["size"][2] > 0 and abs(_on_slope(obj, r) - bottom) < 1e-3 and bottom > 1e-3]
    if not under:
        return obj
    ramp = max(under, key=lambda r: _on_slope(obj, r))
    yaw = ramp.get("yaw", 0.0)
    dx, dy = -math.cos(yaw), -math.sin(yaw)  # a ramp rises along its own +x
    radius = obj["size"][0] / 2
    from aaai.spec import ObjectSpec

    wedges = [ObjectSpec("ramp", "box", tuple(r["position"]), tuple(r["size"]), r.get("yaw", 0.0)) for r in ramps]
    x0, y0 = x, y = obj["position"][0], obj["position"][1]
    level = _ground(x, y, supports, wedges)
    for step in range(1, int(4 * half / ROLL_STEP)):
        nx, ny = x0 + dx * ROLL_STEP * step, y0 + dy * ROLL_STEP * step
        if abs(nx) + radius > half or abs(ny) + radius > half:
            break  # against the arena's wall
        ahead = _ground(nx + dx * radius, ny + dy * radius, supports, wedges)
        here = _ground(nx, ny, supports, wedges)
        if ahead > level + 1e-6 or here > level + 1e-6:
            break  # the ground rises ahead: a face, or a slope up
        x, y, level = nx, ny, here
    high = {**obj, "position": [round(x, 2) + 0.0, round(y, 2) + 0.0, obj["position"][2] + obj["size"][2]]}
    return _settled(high, supports, ramps)
