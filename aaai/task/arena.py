"""Arena files: a level written by hand as YAML, one to one with aaai.spec.LevelSpec.

An arena file's keys are the spec's fields (docs, "Write your own test"):

- ``level``, ``name``, ``difficulty``, ``seed``: what the episode reports. Optional: ``level`` and
  ``name`` default to the ``category``'s (or 0 and ``food_contact``), ``difficulty`` to 0 and
  ``seed`` to the episode's seed;
- ``agent: {x, y, yaw}`` (required; yaw in radians, 0 facing east, pi/2 north);
- ``objects``: a list of ``{kind, shape, position: [x, y, z], size: [sx, sy, sz], yaw, colour:
  [r, g, b, a] or null, mass, behaviour, timing}`` (``kind``, ``position`` and ``size`` required; ``shape``
  default box, food a sphere);
- ``arena_size: [x, y]``, ``wall_height``, ``tiles: [nx, ny]``, ``holes: [[i, j], ...]`` (an item
  may also be ``{rect: [i0, j0, i1, j1]}``: every tile of that block, both ends included),
  ``heightfield`` (rows of heights, or null), ``max_food_reward`` (default: the best food reward the
  objects give: the largest green plus every yellow), ``time_limit`` (seconds), ``blackout:
  {light, dark}`` (repeating), ``{switches: [t1, t2, ...]}`` (dark from t1 to t2, from t3 to t4, ...)
  or null, ``colours: {kind: [r, g, b, a]}``, ``bridge: [x0, y0, x1, y1]`` or null,
  ``inner: {level, name, difficulty, seed}`` or null, ``regenerated``, ``extras`` (any plain data);
- ``pass_mark``: the return at or above which an episode of this arena passes (Animal-AI's
  ``passMark``); kept in the spec's ``extras["pass_mark"]`` (aaai.tools.animalai_coverage.passed); optional;
- ``reach``: ``all`` (default: every piece of food must be reachable) or ``pass_mark`` (food out of
  reach is allowed while the reachable food gives the pass mark, as in Animal-AI's tasks whose
  food behind a barrier is a lure); kept in ``extras["reach"]``;
- ``on_overlap`` (an object's key): ``refuse`` (default) or ``redraw``: placed as Animal-AI's
  ArenaBuilder places an item, drawn again where it overlaps an object before it and left out
  where it cannot be placed (:func:`_place`; the spec's ``extras["left_out"]`` lists those);
- ``walls_cross``: true lets static walls overlap each other (an imported Animal-AI arena's walls that
  Animal-AI places as touching, its spawn check shrinking each by 0.1 %; a wall is static in physics,
  so nothing moves); kept in ``extras["walls_cross"]``;
- and three keys that are not the spec's: ``description`` (one line for people), ``category``
  (the level name, label or id the test belongs to, e.g. ``y_maze``: the scoreboard's summary
  groups by it; an imported Animal-AI arena without one is grouped by ``extras.animalai.category``,
  e.g. ``04 avoidance``) and ``arena_walls`` (true: the four walls round the arena, as the generators'
  ``aaai.levels.common.arena_walls`` builds them, come before ``objects``; default false).

Randomisation: any number may be written ``{uniform: [low, high]}`` (a float drawn uniformly),
``{integers: [low, high]}`` (an integer, both ends included) or ``{choice: [a, b, ...]}`` (one of
the values, which may be any plain data). The draws come, in the file's order, from
``np.random.default_rng([seed, crc32(file name)])``, so one file stands for a family of instances
and the same (file name, seed) gives the same spec.

Errors are ConfigErrors naming the file, the line and the object: an unknown key, a wrong type,
and every problem aaai.levels.validate.check finds (overlapping solids, food that cannot be reached, an
agent inside a wall). Nothing is run from an invalid file.
"""

from __future__ import annotations

import dataclasses
import re
import zlib
from pathlib import Path
from typing import Any, Callable

import numpy as np
import yaml

from aaai import safe_yaml
from aaai.agent.sphere import AAI_DIAMETER, footprint_radius, scale_for
from aaai.config import ConfigError
from aaai.levels import all_levels, get_level, validate
from aaai.levels.common import arena_walls
from aaai.spec import Blackout, InnerLevel, LevelSpec
from aaai.spec.kinds import ENDING_KINDS, OBJECT_KINDS, kind_class
from aaai.task.arena_reader import RANDOM_FORMS, ArenaProblems, Reader, Source

META_KEYS = ("description", "category", "arena_walls", "pass_mark", "reach", "walls_cross")
REACH = ("all", "pass_mark")  # which food must be reachable: every piece, or enough for the pass mark
STEP_COSTS = 1.0  # the most the step term takes from an episode (aaai.task.rewards)
SPEC_KEYS = (
    "level",
    "name",
    "difficulty",
    "seed",
    "agent",
    "objects",
    "arena_size",
    "wall_height",
    "tiles",
    "holes",
    "heightfield",
    "max_food_reward",
    "time_limit",
    "blackout",
    "colours",
    "bridge",
    "inner",
    "regenerated",
    "extras",
)
TOP_KEYS = META_KEYS + SPEC_KEYS
BLACKOUT_KEYS = ("light", "dark")
INNER_KEYS = ("level", "name", "difficulty", "seed")
DEFAULT_TIME_LIMIT = 60.0
MAX_HOLE_TILES = 400 * 400  # tiles the holes list, rects expanded (aaai.levels.validate: at most 400 x 400 tiles)
MAX_OBJECTS = 1000  # objects in an arena file (a generated level has at most a few dozen, an imported one 504)


# --- writing ------------------------------------------------------------------------------
def _plain(value: Any) -> Any:
    """Numpy scalars to Python's, tuples to lists: what yaml.safe_dump can write."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    raise TypeError(f"cannot write {value!r} ({type(value).__name__}) to an arena file")


FIXED_NOTE = (
    "# A fixed arena: the one level instance this was written from. Every episode of it starts alike,\n"
    "# whatever the episode seed; to vary it, put {uniform: [low, high]}, {integers: [low, high]} or\n"
    "# {choice: [...]} in place of a number (docs, Write your own test)."
)


def spec_to_arena(spec: LevelSpec, description: str | None = None, category: str | None = None) -> str:
    """The arena file (YAML text) that loads back to ``spec`` (an equal spec, the same digest)."""
    known = all_levels().get(spec.level)
    data = spec.to_dict()
    head = {
        "description": description
        or (
            f"{known.label if known else 'L' + str(spec.level)} {spec.name} difficulty "
            f"{spec.difficulty} seed {spec.seed}, as generated"
        ),
        "category": category or (known.name if known else spec.name),
    }
    objects = data.pop("objects")
    body = _plain({**head, **{key: data[key] for key in SPEC_KEYS if key != "objects"}})
    lines = [FIXED_NOTE]
    for key, value in body.items():  # holes and heightfield on one line each, the rest as YAML lays it out
        if key == "holes" and value:
            lines.append(f"{key}: " + yaml.safe_dump(value, default_flow_style=True, width=10**6).strip())
            continue
        flow = None if isinstance(value, (list, dict)) and value else False
        lines.append(
            yaml.safe_dump(
                {key: value}, sort_keys=False, default_flow_style=flow, width=10**6, allow_unicode=True
            ).rstrip("\n")
        )
    lines.append("objects:" if objects else "objects: []")
    for index, obj in enumerate(objects):  # one flow mapping per object: one line each, easy to read
        line = yaml.safe_dump(_plain(obj), sort_keys=False, default_flow_style=True, width=10**6).strip()
        lines.append(f"- {line}  # objects[{index}]")
    return "\n".join(lines) + "\n"


def _category(value, source: Source):
    try:
        return get_level(value)
    except ConfigError as error:
        raise source.error(("category",), str(error)) from None


def parse_arena(path: str | Path, seed: int = 0) -> tuple[LevelSpec, dict, Source]:
    """The spec an arena file gives for an episode seed, the file's own keys (description,
    category) and where each key stands; wrong keys and types are errors, validity is not checked."""
    path = Path(path)
    data, node = safe_yaml.load_with_nodes(path, "arena file")  # plain data within limits: size, aliases, depth
    data = {} if data is None else data
    source = Source(path, node if node is not None else yaml.MappingNode("tag:yaml.org,2002:map", []))
    rng = np.random.default_rng([int(seed), zlib.crc32(path.name.encode())])
    read = Reader(source, rng, data)
    if not isinstance(data, dict):
        read.attempt(lambda: read.keys(data, TOP_KEYS, (), required=("agent", "objects")))
        raise ArenaProblems(read.problems)
    read.keys(data, TOP_KEYS, (), required=("agent", "objects"), strict=False)
    attempt = read.attempt
    meta = {"description": data.get("description", ""), "category": None}
    if "description" in data and not isinstance(data["description"], str):
        attempt(lambda: read.fail(("description",), f"got {data['description']!r}; allowed: one line of text"))
    level_id, name = 0, "food_contact"
    if "category" in data:
        try:
            category = attempt(lambda: _category(read.draw(data["category"], ("category",)), source))
        except ConfigError as error:
            category = None
            read.problems.append(str(error))
        if category is not None:
            meta["category"] = category.name
            level_id, name = category.id, category.name
    level = attempt(lambda: read.number(data.get("level", level_id), ("level",), integer=True), level_id)
    name = attempt(lambda: read.text(data.get("name", name), ("name",)), name)
    difficulty = attempt(lambda: read.number(data.get("difficulty", 0), ("difficulty",), integer=True), 0)
    spec_seed = attempt(lambda: read.number(data.get("seed", int(seed)), ("seed",), integer=True), int(seed))
    agent = attempt(lambda: read.agent(read.draw(data["agent"], ("agent",)))) if "agent" in data else None

    def object_list():
        value = read.draw(data["objects"], ("objects",))
        if not isinstance(value, list):
            read.fail(("objects",), f"got {value!r}; allowed: a list of objects")
        if len(value) > MAX_OBJECTS:  # each is checked against every other: thousands would take hours
            read.fail(("objects",), f"got {len(value):,} objects; allowed: at most {MAX_OBJECTS}")
        return value

    objects_value = attempt(object_list, []) if "objects" in data else []
    objects = tuple(
        obj
        for obj in (
            attempt(lambda i=i, obj=obj: read.obj(read.draw(obj, ("objects", i)), i))
            for i, obj in enumerate(objects_value)
        )
        if obj is not None
    )
    fields: dict[str, Any] = {}
    if "arena_size" in data:
        fields["arena_size"] = attempt(
            lambda: read.numbers(data["arena_size"], ("arena_size",), 2, positive=True), (50.0, 50.0)
        )
    if "wall_height" in data:
        fields["wall_height"] = attempt(lambda: read.number(data["wall_height"], ("wall_height",), positive=True), 4.0)
    walls = data.get("arena_walls", False)
    if not isinstance(walls, bool):
        attempt(lambda: read.fail(("arena_walls",), f"got {walls!r}; allowed: true or false"))
    if walls is True:  # they come first, so objects[i] of the file is objects[4 + i] of the spec
        objects = tuple(arena_walls(fields.get("arena_size", (50.0, 50.0)), fields.get("wall_height", 4.0))) + objects
        source.offset = 4
    if "tiles" in data:
        fields["tiles"] = attempt(
            lambda: read.numbers(data["tiles"], ("tiles",), 2, integer=True, positive=True), (1, 1)
        )

    def hole_list():
        holes = read.draw(data["holes"], ("holes",))
        if not isinstance(holes, list):
            read.fail(("holes",), f"got {holes!r}; allowed: a list of [i, j] floor tiles")
        tiles: list[tuple[int, ...]] = []
        for i, hole in enumerate(holes):
            hole = read.draw(hole, ("holes", i))
            if isinstance(hole, dict):  # {rect: [i0, j0, i1, j1]}: every tile in that block, both ends included
                read.keys(hole, ("rect",), ("holes", i), required=("rect",))
                i0, j0, i1, j1 = read.numbers(hole["rect"], ("holes", i, "rect"), 4, integer=True)
                if i0 > i1 or j0 > j1:
                    read.fail(
                        ("holes", i, "rect"), f"got {hole['rect']!r}; allowed: [i0, j0, i1, j1], i0 <= i1, j0 <= j1"
                    )
                nx, ny = fields.get("tiles", (1, 1))
                if i0 < 0 or j0 < 0 or i1 >= nx or j1 >= ny:  # checked before the block's tiles are listed
                    read.fail(
                        ("holes", i, "rect"),
                        f"got {hole['rect']!r}; allowed: a block within the {nx} x {ny} floor tiles "
                        f"(i from 0 to {nx - 1}, j from 0 to {ny - 1})",
                    )
                if len(tiles) + (i1 - i0 + 1) * (j1 - j0 + 1) > MAX_HOLE_TILES:
                    read.fail(
                        ("holes", i, "rect"),
                        f"the holes list more than {MAX_HOLE_TILES:,} tiles; allowed: at most {MAX_HOLE_TILES:,} "
                        "(the largest floor, 400 x 400)",
                    )
                tiles += [(a, b) for a in range(i0, i1 + 1) for b in range(j0, j1 + 1)]
            else:
                tiles.append(read.numbers(hole, ("holes", i), 2, integer=True))
        return tuple(tiles)

    if "holes" in data:
        fields["holes"] = attempt(hole_list, ())
    fields["heightfield"] = attempt(
        lambda: read.optional(
            "heightfield",
            lambda rows: (
                tuple(read.numbers(row, ("heightfield", i), None) for i, row in enumerate(rows))
                if isinstance(rows, list)
                else read.fail(("heightfield",), f"got {rows!r}; allowed: null or a list of rows of heights")
            ),
        )
    )

    def time_limit():
        value = read.number(data.get("time_limit", DEFAULT_TIME_LIMIT), ("time_limit",), positive=True)
        if not 0.2 <= value <= validate.MAX_TIME_LIMIT:
            read.fail(("time_limit",), f"got {value!r}; allowed: 0.2 to {validate.MAX_TIME_LIMIT:g} seconds")
        return value

    fields["time_limit"] = attempt(time_limit, DEFAULT_TIME_LIMIT)

    def blackout(value):
        if isinstance(value, dict) and "switches" in value:  # listed times, as Animal-AI's listed frames
            read.keys(value, ("switches",), ("blackout",), required=("switches",))
            times = read.numbers(value["switches"], ("blackout", "switches"), None)
            if not times or any(t < 0 for t in times) or any(b <= a for a, b in zip(times, times[1:])):
                read.fail(
                    ("blackout", "switches"),
                    f"got {value['switches']!r}; allowed: one or more times (seconds, 0 or more, rising) at "
                    "which the light goes off, on, off, ...",
                )
            return Blackout(0.0, 0.0, tuple(float(t) for t in times))
        read.keys(value, BLACKOUT_KEYS, ("blackout",), required=BLACKOUT_KEYS)
        return Blackout(*(read.number(value[k], ("blackout", k), positive=True) for k in BLACKOUT_KEYS))

    def inner(value):
        read.keys(value, INNER_KEYS, ("inner",), required=INNER_KEYS)
        return InnerLevel(
            read.number(value["level"], ("inner", "level"), integer=True),
            read.text(value["name"], ("inner", "name")),
            read.number(value["difficulty"], ("inner", "difficulty"), integer=True),
            read.number(value["seed"], ("inner", "seed"), integer=True),
        )

    def colours(value):
        if not isinstance(value, dict):
            read.fail(("colours",), f"got {value!r}; allowed: a mapping from kind to [r, g, b, a]")
        for kind in value:
            if kind not in OBJECT_KINDS:
                read.fail(("colours", kind), f"kind {kind!r} does not exist; allowed: {', '.join(OBJECT_KINDS)}")
        return {kind: read.numbers(rgba, ("colours", kind), 4) for kind, rgba in value.items()}

    fields["blackout"] = attempt(lambda: read.optional("blackout", blackout))
    fields["colours"] = attempt(lambda: read.optional("colours", colours)) or {}
    fields["bridge"] = attempt(lambda: read.optional("bridge", lambda v: read.numbers(v, ("bridge",), 4)))
    fields["inner"] = attempt(lambda: read.optional("inner", inner))
    fields["regenerated"] = attempt(lambda: read.number(data.get("regenerated", 0), ("regenerated",), integer=True), 0)

    def extras():
        value = read.plain(data.get("extras", {}), ("extras",))
        if not isinstance(value, dict):
            read.fail(("extras",), f"got {value!r}; allowed: a mapping of plain data")
        return value

    fields["extras"] = attempt(extras, {})
    imported = (fields["extras"] or {}).get("animalai")
    if meta["category"] is None and isinstance(imported, dict) and isinstance(imported.get("category"), str):
        meta["category"] = imported["category"]  # an imported Animal-AI arena's category (aaai.tools.animalai_arena)
    if "pass_mark" in data:
        mark = attempt(lambda: read.number(data["pass_mark"], ("pass_mark",)))
        if mark is not None:
            fields["extras"] = {**(fields["extras"] or {}), "pass_mark": float(mark)}
    if "walls_cross" in data:
        cross = data["walls_cross"]
        if not isinstance(cross, bool):
            attempt(lambda: read.fail(("walls_cross",), f"got {cross!r}; allowed: true or false"))
        elif cross:
            fields["extras"] = {**(fields["extras"] or {}), "walls_cross": True}
    if "reach" in data:
        reach = attempt(lambda: read.text(data["reach"], ("reach",), REACH))
        if reach == "pass_mark" and "pass_mark" not in data:
            attempt(
                lambda: read.fail(("reach",), "got 'pass_mark' without a pass_mark; allowed: all, or set pass_mark")
            )
        elif reach is not None:
            fields["extras"] = {**(fields["extras"] or {}), "reach": reach}
    if not read.problems and agent is not None:  # objects to be drawn again where they overlap (Animal-AI's rule)
        head = (level, name, difficulty, spec_seed, agent)
        objects, left_out = _place(
            read, objects_value, objects, source.offset, lambda placed: LevelSpec(*head, placed, **fields)
        )
        if left_out:
            fields["extras"] = {**(fields["extras"] or {}), "left_out": left_out}
    if "max_food_reward" in data:
        fields["max_food_reward"] = attempt(lambda: read.number(data["max_food_reward"], ("max_food_reward",)), 0.0)
    else:
        green = [o.food_value for o in objects if o.is_food and o.kind in ENDING_KINDS]
        fields["max_food_reward"] = max(green, default=0.0) + sum(
            o.food_value for o in objects if o.is_food and o.kind not in ENDING_KINDS
        )
    if read.problems:
        raise ArenaProblems(read.problems)
    assert agent is not None  # a missing or unreadable agent is a problem
    spec = LevelSpec(level, name, difficulty, spec_seed, agent, objects, **fields)
    return spec, meta, source


REDRAW_ATTEMPTS = 20  # Animal-AI's ArenaBuilder: draws of a random item's place before it is left out


def _place(
    read: Reader, values: list, objects: tuple, offset: int, spec_of: Callable[[tuple], LevelSpec]
) -> tuple[tuple, list[int]]:
    """The objects as Animal-AI's ArenaBuilder places them, for those whose file says ``on_overlap:
    redraw``: in order, each that overlaps an object before it (validate.overlaps_earlier) has its
    random numbers drawn again, up to REDRAW_ATTEMPTS draws in all, and is left out when every draw
    overlaps (one with no random number at once). The draws come after every other draw of the
    file, so a file whose objects never overlap gives the spec it gave before. Returns the objects
    and the file indices of those left out."""
    placed: list = list(objects)
    left_out: list[int] = []
    for i, value in enumerate(values):
        if not (isinstance(value, dict) and value.get("on_overlap") == "redraw"):
            continue
        k = offset + i - len(left_out)
        random = _has_draw(value)
        for draw in range(REDRAW_ATTEMPTS if random else 1):
            if draw:
                placed[k] = read.obj(read.draw(value, ("objects", i)), i)
            if not validate.overlaps_earlier(spec_of(tuple(placed[: k + 1])), k):
                break
        else:
            del placed[k]
            left_out.append(i)
    return tuple(placed), left_out


def _has_draw(value) -> bool:
    """Whether a file's value holds a randomisation form anywhere."""
    if isinstance(value, dict):
        return (len(value) == 1 and next(iter(value)) in RANDOM_FORMS) or any(_has_draw(v) for v in value.values())
    if isinstance(value, list):
        return any(_has_draw(v) for v in value)
    return False


_OBJECT_REF = re.compile(
    r"(" + "|".join(sorted(OBJECT_KINDS, key=len, reverse=True)) + r") at "
    r"\((-?\d+\.\d), (-?\d+\.\d)\)"
)
_INDEX_REF = re.compile(r"object (\d+) \((\w+)\)")


def _located(spec: LevelSpec, source: Source, problem: str) -> str:
    """A validate.check message with the file, the line and the objects it names by index."""
    indices: list[int] = []  # the spec's object indices named, in order

    def name(index: int) -> str:
        mine = index - source.offset
        return f"objects[{mine}]" if mine >= 0 else f"arena_walls[{index}]"

    def line(index: int) -> int:
        mine = index - source.offset
        return source.line(("objects", mine) if mine >= 0 else ("arena_walls",))

    def by_place(match: re.Match) -> str:
        kind, x, y = match.group(1), match.group(2), match.group(3)
        for index, obj in enumerate(spec.objects):
            if index in indices or obj.kind != kind:
                continue
            places = [obj.position, *validate.food_places(obj)[1:]] if obj.is_food else [obj.position]
            if any(validate._xy(place) == f"({x}, {y})" for place in places):
                indices.append(index)
                return f"{name(index)} ({kind}) at ({x}, {y})"
        return match.group(0)

    def by_index(match: re.Match) -> str:
        indices.append(int(match.group(1)))
        return f"{name(int(match.group(1)))} ({match.group(2)})"

    text = _INDEX_REF.sub(by_index, _OBJECT_REF.sub(by_place, problem))
    text = re.sub(r"^solid objects overlap: (.*?) and (.*)$", r"\1 overlaps \2", text)
    text = re.sub(r"^objects overlap exactly: (.*?) and (.*)$", r"\1 is exactly where \2 is", text)
    if indices:
        first = indices[0]
        label = f"{name(first)} ({spec.objects[first].kind})"
        text = text.replace(f"{label} at ", "at ", 1).replace(f"{label}'s ", "its ", 1)
        return f"{source.name} line {line(first)}, {label}: {text}"
    if "agent's start" in problem:
        return f"{source.name} line {source.line(('agent',))}, agent: {problem}"
    for key, words in (("arena_size", "arena size"), ("tiles", "floor tiles"), ("holes", "hole lies")):
        if words in problem:
            return f"{source.name} line {source.line((key,))}, {key}: {problem}"
    return f"{source.name} line {source.line(())}: {problem}"


# why a pass mark is out of reach though every piece is in reach (check_arena)
ENDING_IN_THE_WAY = "the pieces it needs lie past food that ends the episode, too close to pass without touching it"
LAST_ENDS = "the last multi_food piece eaten ends the episode, as a green does: not all of both can be eaten"
_WALLS_CROSS = re.compile(r"solid objects overlap: (transparent_)?wall at \([^)]*\) and (transparent_)?wall at ")


def footprint_for(body: str, arena_size=None) -> float:
    """The footprint radius ``body`` (agent.body) is validated with in an arena of ``arena_size`` (None: the
    generated levels'): the walking bodies' FOOTPRINT_RADIUS; the sphere's own radius there plus its margin
    (aaai.agent.sphere.footprint_radius: 3.0 in an imported arena 200 across)."""
    return footprint_radius(arena_size) if body == "sphere" else validate.FOOTPRINT_RADIUS


def reachable_return(spec: LevelSpec, body: str = "quadruped") -> float:
    """The most an episode can return eating only the food the body can reach: the best reachable
    episode-ending piece plus every other piece reachable without touching one that ends the episode
    (:func:`_ending_blocked`), but one piece of a kind whose last piece ends the episode (:func:`_last_of_kind`),
    or those pieces without the ending one, whichever is more; less the most the step term takes. From a
    start on a ledge, the best of the regions it may step down into (it takes one: the first of :func:`sides`)."""
    return _pass_mark_returns(spec, body)[0]


def _pass_mark_returns(spec: LevelSpec, body: str) -> tuple[float, float, float]:
    """(:func:`reachable_return`; the same as if a body could pass through a piece that ends the episode;
    and as if the last multi_food did not end it either, :func:`_region_return`), each less the step term's
    most, from one pair of reach maps: the last two name why a pass mark is out of reach (check_arena)."""
    footprint = footprint_for(body, spec.arena_size)
    speed = validate.walk_speed(footprint)
    regions = validate.reach_regions(spec, footprint)
    blocked = _ending_blocked(spec)
    around = validate.reach_regions(blocked, footprint) if blocked is not spec else regions
    best = through = every = 0.0  # (no region: the start is not clear)
    for region in regions:
        reached = [food for food in spec.foods if validate.food_reachable(spec, region, food, speed)]
        ending = max((food.food_value for food in reached if food.kind in ENDING_KINDS), default=0.0)
        near = [other for other in around if (other & region).any()]  # the same region, less the ending pieces
        rounded = [
            food
            for food in blocked.foods
            if food.kind not in ENDING_KINDS and any(validate.food_reachable(blocked, r, food, speed) for r in near)
        ]
        best = max(best, _with_ending(spec, ending, rounded))
        through = max(through, _with_ending(spec, ending, [f for f in reached if f.kind not in ENDING_KINDS]))
        every = max(every, _region_return(spec, region, speed))
    return best - STEP_COSTS, through - STEP_COSTS, every - STEP_COSTS


def _with_ending(spec: LevelSpec, ending: float, others: list) -> float:
    """The most from ``others`` (pieces that do not end the episode) and an ending piece worth ``ending``:
    all of them, or the ending piece too, less what eating it as well costs (:func:`_last_of_kind`)."""
    total = sum(food.food_value for food in others)
    return max(total, ending + total - _last_of_kind(spec, others))


def _last_of_kind(spec: LevelSpec, reached: list) -> float:
    """What eating an episode-ending piece as well costs of ``reached`` (pieces that do not end the episode):
    of a kind whose every piece eaten ends the episode (multi_food), when every piece of it is reached, one
    must be left for the ending piece to be eaten: the least of them (0 when no kind is so)."""
    cost = 0.0
    for kind in {food.kind for food in reached if (cls := kind_class(food.kind)) is not None and cls.all_end}:
        mine = [food.food_value for food in reached if food.kind == kind]
        if len(mine) == sum(food.kind == kind for food in spec.foods):
            cost += min(mine)
    return cost


def _ending_blocked(spec: LevelSpec) -> LevelSpec:
    """The spec with each unmoving piece that ends the episode (ENDING_KINDS: green, growing, shrinking or bad
    food) standing as a solid pillar of its size: the body that touches one has eaten it, so the other food
    counts only if it can be reached round them. The spec itself when it has none."""
    ending = [i for i, obj in enumerate(spec.objects) if obj.kind in ENDING_KINDS and obj.behaviour is None]
    if not ending:
        return spec
    objects = list(spec.objects)
    for i in ending:
        objects[i] = dataclasses.replace(objects[i], kind="pillar", shape="box", mass=0.0)
    return dataclasses.replace(spec, objects=tuple(objects) if isinstance(spec.objects, tuple) else objects)


def sides(spec: LevelSpec, body: str = "quadruped") -> list[tuple[float, np.ndarray]]:
    """(worth, region) of each region the body may step down into from a start on a ledge, worth most
    first (equals in the order of aaai.levels.validate.reach_regions; the first is the side a start on a
    ledge takes); empty without a ledge. A region's
    worth is the food the head can get to in it (a bouncing piece where the body gets in time)."""
    if validate.start_ledge(spec) is None:
        return []
    regions = validate.reach_regions(spec, footprint_for(body, spec.arena_size))
    return sorted(((_region_return(spec, region), region) for region in regions), key=lambda pair: -pair[0])


def _region_return(spec: LevelSpec, region: np.ndarray, speed: float | None = validate.WALK_SPEED) -> float:
    reached = [food for food in spec.foods if validate.food_reachable(spec, region, food, speed)]
    ending = [food.food_value for food in reached if food.kind in ENDING_KINDS]
    return max(ending, default=0.0) + sum(f.food_value for f in reached if f.kind not in ENDING_KINDS)


def check_arena(spec: LevelSpec, source: Source, require_food: bool = True, body: str = "quadruped") -> list[str]:
    """validate.check's problems with the spec for ``body``'s footprint (:func:`footprint_for`), each naming
    the file, the line and the object. With ``reach: pass_mark``, food that cannot be reached is no problem
    while the food that can be reached gives the pass mark (:func:`reachable_return`); when it does not, that
    is one more problem."""
    problems = validate.check(spec, require_food=require_food, footprint=footprint_for(body, spec.arena_size))
    ledge = validate.start_ledge(spec) if body == "sphere" else None
    radius = AAI_DIAMETER / 2 * scale_for(spec.arena_size)  # the sphere's (aaai.agent.sphere.Sphere.fit)
    if ledge is not None and ledge.position[2] + ledge.size[2] / 2 < radius:
        # measured: the sphere rolls up a step lower than its radius (1.5 and 2 with a radius of 2.5), not
        # one as high (2.5, 3): from the floor it would get back on to the ledge
        problems.append(
            f"the agent's start ({spec.agent.x:.1f}, {spec.agent.y:.1f}) on a ledge is not clear for the sphere: "
            f"the ledge, {ledge.position[2] + ledge.size[2] / 2:g} high, is lower than its radius {radius:g}, "
            "so it rolls back up on to it"
        )
    if spec.extras.get("walls_cross"):  # static walls that overlap, as Animal-AI places touching ones
        problems = [p for p in problems if not _WALLS_CROSS.match(p)]
    if spec.extras.get("reach") == "pass_mark":
        unreached = [p for p in problems if p.endswith("cannot be reached from the start")]
        on_ledge = validate.start_ledge(spec) is not None  # the food of the one side it steps down to counts
        problems = [p for p in problems if p not in unreached]
        start_blocked = not validate.reach_regions(spec, footprint_for(body, spec.arena_size))  # no region: not clear
        if unreached or on_ledge or ("pass_mark" in spec.extras and not start_blocked):
            # also with every piece in reach: a pass mark above all the arena pays is passed by no body
            (best, through, every), mark = _pass_mark_returns(spec, body), spec.extras["pass_mark"]
            if best < mark:
                why = (
                    f"{len(unreached)} piece{'s' if len(unreached) > 1 else ''} of food out of reach"
                    if unreached
                    else "from a ledge, the food of one side"
                    if on_ledge
                    else ENDING_IN_THE_WAY
                    if through >= mark
                    else LAST_ENDS
                    if every >= mark
                    else "all the arena's food, every piece in reach"
                )
                problems.append(
                    f"the food that can be reached gives at most {best:.2f}, below the pass mark {mark:g} ({why})"
                )
    return [_located(spec, source, problem) for problem in problems]


def load_arena(path: str | Path, seed: int = 0, require_food: bool = True, body: str = "quadruped") -> LevelSpec:
    """The level an arena file gives for an episode seed, checked as a generated level is
    (aaai.levels.validate.check) for ``body``'s footprint: an invalid one is a ConfigError listing its problems
    by file, line and object."""
    spec, _, source = parse_arena(path, seed)
    problems = check_arena(spec, source, require_food, body)
    if problems:
        raise ArenaProblems(problems)
    return spec


def arena_meta(path: str | Path) -> dict:
    """An arena file's description and category (the category's level name, or None)."""
    return parse_arena(path, 0)[1]


def arena_files(path: str | Path) -> list[Path]:
    """A file, or a folder's *.yaml files in name order."""
    path = Path(path)
    if path.is_dir():
        files = sorted(path.glob("*.yaml")) + sorted(path.glob("*.yml"))
        if not files:
            raise ConfigError(f"arena folder {str(path)!r} holds no .yaml files")
        return files
    if not path.is_file():
        raise ConfigError(f"arena {str(path)!r} is neither a file nor a folder")
    return [path]
