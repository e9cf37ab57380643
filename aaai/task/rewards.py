"""The food-finding task: each step's contacts as events, the events as reward terms, the episode's end.

T is episode.max_steps. Every step costs 0.5/T, and another 0.5/T while the head touches
the floor (with ground_penalty off: 1/T flat). Food eaten with the head pays its value
(green: size, yellow: size/2); with a leg, as agent.limb_food_reward says. Each new
contact of a body part with a wall costs 1 (standing on a wall's top is footing, not a hit); falling
onto the deadly floor costs 1. The newer
kinds (aaai.spec.kinds): bad food touched by any part pays -size and ends the episode; a death zone
touched is a fall; while a hot zone is touched the step term is ten times as large. Food that
ripens, decays, grows or shrinks pays its value at the time it is eaten (aaai.spec.kinds.TimedFood).
Optional potential-based shaping (episode.shaping = k > 0) adds k x (how much nearer the head
came to the nearest food this step); evaluation always runs with k = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

from aaai.config import EpisodeConfig
from aaai.spec import LevelSpec, ObjectSpec
from aaai.spec.kinds import EDIBLE_KINDS, ENDING_KINDS, HOT_ZONE_FACTOR, KIND_INDEX, KINDS, REGISTRY, TimedFood

LIMB_FLAT_REWARD = {"food_green": 1.0, "food_yellow": 0.5, **{k: c.flat_value for k, c in REGISTRY.items() if c.edible}}
ANY_PART = tuple(k for k, c in REGISTRY.items() if c.any_part)  # eaten by any part of the body (bad food)
TERMS = ("step", "ground", "food", "wall", "fall", "shaping")
FLOOR, WALL, DEADLY = KIND_INDEX["floor"], KIND_INDEX["wall"], KIND_INDEX["deadly_floor"]
FOOD = tuple(KIND_INDEX[kind] for kind in EDIBLE_KINDS)
# A contact with a wall whose normal (on the wall, towards the body) points up more steeply than this is
# footing on its top (a platform, a raised floor the body walks on), not a hit: it costs nothing, and the
# head resting there is the head on the floor. 0.7: within about 45 degrees of straight up.
FOOTING = 0.7
NEWER = len(KINDS)  # kind indices from here on are aaai.spec.kinds plug-ins
NEWER_CLASSES = tuple(REGISTRY.values())
HEAD = -1  # the head's link index in a contact


@dataclass
class StepEvents:
    head_on_floor: bool = False
    eaten: dict[int, tuple[ObjectSpec, bool]] = field(default_factory=dict)  # body -> (food, by the head)
    new_wall_hits: int = 0
    fell: bool = False
    hot: bool = False  # a part of the body touches a hot zone
    seconds: float = 0.0  # simulated time at the end of this step: the value of food that ripens or decays

    @property
    def green_eaten(self) -> bool:
        """A piece that ends the episode is eaten (a green, or bad food)."""
        return bool(self.eaten) and any(food.kind in ENDING_KINDS for food, _ in self.eaten.values())


def limb_eats(limb_food_reward: str) -> bool:
    return limb_food_reward != "none"


def food_reward(food: ObjectSpec, by_head: bool, limb_food_reward: str, seconds: float = 0.0) -> float:
    """What eating ``food`` pays ``seconds`` into the episode (only timed food's value depends on it)."""
    if by_head or limb_food_reward == "size" or food.kind in ANY_PART:
        kind = REGISTRY.get(food.kind)
        return kind.value_at(food, seconds) if kind is not None and issubclass(kind, TimedFood) else food.food_value
    return LIMB_FLAT_REWARD[food.kind] if limb_food_reward == "flat" else 0.0


def step_reward(events: StepEvents, max_steps: int, ground_penalty: bool, limb_food_reward: str) -> dict[str, float]:
    """Reward terms of one step; their sum is the step's reward."""
    unit = 0.5 / max_steps
    return {
        "step": -unit * HOT_ZONE_FACTOR if events.hot else -unit,
        "ground": -unit if (events.head_on_floor or not ground_penalty) else 0.0,
        "food": sum(
            food_reward(food, by_head, limb_food_reward, events.seconds) for food, by_head in events.eaten.values()
        )
        if events.eaten
        else 0,
        "wall": -1.0 * events.new_wall_hits,
        "fall": -1.0 if events.fell else 0.0,
        "shaping": 0.0,  # set by FoodTask when episode.shaping > 0 (training only)
    }


def nearest_food_distance(head, food_positions) -> float:
    """Horizontal distance from the head to the nearest of ``food_positions`` (0 if none)."""
    return min((math.dist(head[:2], position[:2]) for position in food_positions), default=0.0)


class FoodTask:
    """The task of one environment, in the hooks of a control step (as dm_control's tasks):
    ``initialize_episode`` after the level is built, ``after_step`` to read the step's contacts,
    ``get_reward`` for its terms, ``should_terminate`` / ``should_truncate`` for the episode's end.

    It keeps the episode's counts: food eaten, wall hits, the walls touched now.
    """

    def __init__(self, episode: EpisodeConfig, limb_food_reward: str, control_dt: float, head_rests: bool = False):
        """``head_rests``: the body rests on its head (the sphere), so its touching the floor is no
        "head on the floor" for the ground penalty."""
        self.head_rests = head_rests
        self.max_steps_setting = episode.max_steps  # "auto": the level's own time limit
        self.ground_penalty = episode.ground_penalty
        self.shaping, self.shaping_gamma = episode.shaping, episode.shaping_gamma
        self.limb_food_reward = limb_food_reward
        self.control_dt = control_dt
        self.max_steps = 0  # T of the current episode
        self.food_eaten = self.wall_hits = 0
        self.steps = 0  # control steps read this episode: the clock of timed food
        self.food_distance = 0.0
        self.wall_contacts: set[tuple[int, int]] = set()

    def episode_steps(self, spec: LevelSpec) -> int:
        """T for a level instance: episode.max_steps, or with "auto" the level's time limit in steps."""
        if isinstance(self.max_steps_setting, int):  # else "auto"
            return self.max_steps_setting
        return max(1, round(spec.time_limit / self.control_dt))

    def initialize_episode(self, spec: LevelSpec, head, food_positions: Callable[[], list]) -> None:
        """``food_positions()`` says where the food in the world is; asked only when shaping."""
        self.max_steps = self.episode_steps(spec)
        self.wall_contacts = set()
        self.food_eaten = self.wall_hits = 0
        self.steps = 0
        self.food_distance = nearest_food_distance(head, food_positions()) if self.shaping else 0.0

    def after_step(self, contacts, kind_index, food: dict[int, ObjectSpec]) -> StepEvents:
        """Turns the body's contacts of this step into events: the head on the floor, new wall
        hits, a fall onto the deadly floor, food eaten (with the head; with a leg if legs eat)."""
        self.steps += 1
        events = StepEvents(seconds=self.steps * self.control_dt)
        touching: dict[int, bool] = {}  # food body -> touched by the head
        walls_now: set[tuple[int, int]] = set()
        known = len(kind_index)
        for contact in contacts:
            other, link = contact[2], contact[3]
            kind = kind_index[other] if other < known else -1
            if kind == FLOOR:
                events.head_on_floor |= link == HEAD and not self.head_rests
            elif kind == WALL and contact[7][2] > FOOTING:  # on the wall's top: it stands there, as on the floor
                events.head_on_floor |= link == HEAD and not self.head_rests
            elif kind == WALL:
                walls_now.add((link, other))
            elif kind == DEADLY:
                events.fell = True
            elif kind in FOOD:
                touching[other] = touching.get(other, False) or link == HEAD
            elif kind >= NEWER:  # a floor area (aaai.spec.kinds): deadly, or hot
                newer = NEWER_CLASSES[kind - NEWER]
                events.fell |= newer.deadly
                events.hot |= newer.hot
                events.head_on_floor |= newer.zone and link == HEAD and not self.head_rests
        events.new_wall_hits = len(walls_now - self.wall_contacts)
        self.wall_contacts = walls_now
        self.wall_hits += events.new_wall_hits
        if touching:
            limbs_eat = limb_eats(self.limb_food_reward)
            for body, by_head in sorted(touching.items()):
                if by_head or limbs_eat or food[body].kind in ANY_PART:
                    events.eaten[body] = (food[body], by_head)
            self.food_eaten += sum(piece.is_food for piece, _ in events.eaten.values())
        return events

    def get_reward(self, events: StepEvents, head, food_positions: Callable[[], list]) -> dict[str, float]:
        """The step's reward terms (their sum is the step's reward), after the eaten food has left
        the world."""
        terms = step_reward(events, self.max_steps, self.ground_penalty, self.limb_food_reward)
        if self.shaping:
            terms["shaping"] = self.shaping_reward(nearest_food_distance(head, food_positions()))
        return terms

    def shaping_reward(self, distance: float) -> float:
        """Potential-based shaping, gamma x potential(now) - potential(before), with potential =
        -shaping x distance to the nearest food (Ng, Harada and Russell, 1999). With gamma 1 (the
        default) an episode's shaping adds up to shaping x (start distance - end distance); with
        gamma < 1, standing far from the food pays a little every step."""
        reward = self.shaping * (self.food_distance - self.shaping_gamma * distance)
        self.food_distance = distance
        return reward

    @staticmethod
    def should_terminate(events: StepEvents, all_eaten: bool) -> bool:
        """The green is eaten, the agent fell, or no food is left that it can still reach."""
        return events.green_eaten or events.fell or all_eaten

    def should_truncate(self, steps: int, blew_up: bool) -> bool:
        return blew_up or steps >= self.max_steps
