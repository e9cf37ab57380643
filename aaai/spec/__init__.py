"""A level as plain data: what a generator returns and the builder turns into PyBullet bodies.

A spec holds no simulator state, so it can be validated, drawn and hashed without physics. The
names it is written in live beside it, below the simulation: the object kinds (aaai.spec.kinds) and
the moving parts (aaai.spec.behaviours); this package imports nothing of aaai.sim, aaai.task or
aaai.levels.
Coordinates: metres, z up, the arena centred on the origin with its floor's top at z = 0;
yaw in radians, 0 facing +x (east), pi/2 facing +y (north).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field

from aaai.spec import behaviours, dispensers, kinds
from aaai.spec.behaviours import names as behaviour_names
from aaai.spec.kinds import COLOURS, EDIBLE_KINDS, FOOD_KINDS, TimedFood, check_kind, kind_class

# The spawner and button kinds (neither food nor edible), registered before any other module reads the tables.
dispensers.define(kinds.Kind, kinds.register, behaviours.Behaviour, behaviours.register)

SHAPES = ("box", "sphere", "cylinder")


def _drop_no_timing(data) -> None:
    """Takes ``timing: None`` out of every object in a spec's dict."""
    if isinstance(data, dict):
        if "kind" in data and "timing" in data and data["timing"] is None:
            del data["timing"]
        if "light" in data and "dark" in data and data.get("switches") == ():
            del data["switches"]  # a periodic blackout has the digest it had before switches existed
        for value in data.values():
            _drop_no_timing(value)
    elif isinstance(data, (list, tuple)):
        for value in data:
            _drop_no_timing(value)


@dataclass(frozen=True)
class ObjectSpec:
    kind: str
    shape: str
    position: tuple[float, float, float]  # centre
    size: tuple[float, float, float]  # full extents; a sphere's diameter thrice
    yaw: float = 0.0
    colour: tuple[float, float, float, float] | None = None  # None: the kind's colour
    mass: float = 0.0  # 0: static
    behaviour: dict | None = None  # a moving part (aaai.spec.behaviours), e.g. {"type": "random_walk", "speed": 4.0}
    timing: dict | None = None  # food whose value changes (aaai.spec.kinds.TimedFood): start, end, delay, duration

    def __post_init__(self):
        check_kind(self.kind)
        if self.shape not in SHAPES:
            raise ValueError(f"object shape {self.shape!r} is not known; allowed: {', '.join(SHAPES)}")
        if min(self.size) <= 0:
            raise ValueError(f"object size {self.size} must be positive")
        if self.behaviour is not None and self.behaviour.get("type") not in behaviour_names():
            raise ValueError(f"object behaviour {self.behaviour!r}; allowed types: {', '.join(behaviour_names())}")

    @property
    def rgba(self) -> tuple[float, float, float, float]:
        return self.colour if self.colour is not None else COLOURS[self.kind]

    @property
    def is_food(self) -> bool:
        return self.kind in FOOD_KINDS

    @property
    def is_edible(self) -> bool:
        """Eaten on contact: food, and the kinds with a reward of their own (bad food)."""
        return self.kind in EDIBLE_KINDS

    @property
    def food_value(self) -> float:
        """Reward for eating this piece with the head: its size (green) or half its size (yellow);
        a newer kind's value per unit of size (aaai.spec.kinds) times its size."""
        if self.kind == "food_green":
            return self.size[0]
        if self.kind == "food_yellow":
            return self.size[0] / 2
        cls = kind_class(self.kind)
        if cls is not None and issubclass(cls, TimedFood):  # the timed kinds (``timed``)
            return cls.best_value(self)  # its best; the value when eaten: aaai.spec.kinds.TimedFood.value_at
        return cls.value * self.size[0] if cls is not None and cls.edible else 0.0


@dataclass(frozen=True)
class AgentPose:
    x: float
    y: float
    yaw: float


@dataclass(frozen=True)
class Blackout:
    """L7's camera schedule: it sees for ``light`` seconds, then is dark for ``dark``, repeating; or,
    when ``switches`` (seconds, rising) is given, it sees until the first, is dark until the second,
    and so on (Animal-AI's blackouts at listed frames; light and dark are then 0)."""

    light: float
    dark: float
    switches: tuple[float, ...] = ()


@dataclass(frozen=True)
class InnerLevel:
    """The level, cell and seed a wrapping level (L6, L7) was built from."""

    level: int
    name: str
    difficulty: int
    seed: int


@dataclass(frozen=True)
class LevelSpec:
    level: int
    name: str
    difficulty: int
    seed: int
    agent: AgentPose
    objects: tuple[ObjectSpec, ...]
    arena_size: tuple[float, float] = (50.0, 50.0)
    wall_height: float = 4.0
    tiles: tuple[int, int] = (1, 1)  # floor tiles along x and y
    holes: tuple[tuple[int, int], ...] = ()  # (i, j) of floor tiles left out
    # Rough terrain instead of flat tiles: heights (rows along y, columns along x) spanning the
    # arena, or None for a flat floor.
    heightfield: tuple[tuple[float, ...], ...] | None = None
    max_food_reward: float = 0.0  # best food reward this instance can give
    time_limit: float = 20.0  # seconds of simulated time an episode may last (T = this / control step)
    blackout: Blackout | None = None  # the camera's dark periods (L7), or None
    colours: dict = field(default_factory=dict)  # kind -> (r, g, b, a) replacing the kinds' colours (L6)
    # Floor again once the pushable plank has tipped over (L10): x0, y0, x1, y1 where it lands.
    bridge: tuple[float, float, float, float] | None = None
    inner: InnerLevel | None = None  # the level a wrapping level (L6, L7) was built from
    regenerated: int = 0  # attempts that failed aaai.levels.validate.check before this one
    extras: dict = field(default_factory=dict)  # facts about the instance for people and analysis (JSON types)

    def to_dict(self) -> dict:
        data = asdict(self)
        _drop_no_timing(data)  # a spec without timed food (or switches) has the digest it had before they existed
        return data

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))

    def digest(self) -> str:
        """A hash of the whole spec: equal specs have equal digests, in any process."""
        return hashlib.sha256(self.to_json().encode()).hexdigest()

    @property
    def foods(self) -> list[ObjectSpec]:
        return [obj for obj in self.objects if obj.is_food]


def generator_fields(spec: LevelSpec) -> dict:
    """A spec as the dict a generator returns, to wrap one level in another."""
    return {
        "agent": (spec.agent.x, spec.agent.y, spec.agent.yaw),
        "objects": list(spec.objects),
        "max_food_reward": spec.max_food_reward,
        "time_limit": spec.time_limit,
        "arena_size": spec.arena_size,
        "wall_height": spec.wall_height,
        "tiles": spec.tiles,
        "holes": spec.holes,
        "heightfield": spec.heightfield,
        "blackout": spec.blackout,
        "colours": dict(spec.colours),
        "bridge": spec.bridge,
        "inner": InnerLevel(spec.level, spec.name, spec.difficulty, spec.seed),
        "extras": dict(spec.extras),
    }
