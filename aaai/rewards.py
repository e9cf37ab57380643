"""The reward of one control step, by term, from the step's events.

T is episode.max_steps. Every step costs 0.5/T, and another 0.5/T while the head touches
the floor (with ground_penalty off: 1/T flat). Food eaten with the head pays its value
(green: size, yellow: size/2); with a leg, as agent.limb_food_reward says. Each new
contact of a body part with a wall costs 1; falling onto the deadly floor costs 1.
Optional potential-based shaping (episode.shaping = k > 0) adds k x (how much nearer the head
came to the nearest food this step); evaluation always runs with k = 0.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from aaai.spec import ObjectSpec

LIMB_FLAT_REWARD = {"food_green": 1.0, "food_yellow": 0.5}
TERMS = ("step", "ground", "food", "wall", "fall", "shaping")


@dataclass
class StepEvents:
    head_on_floor: bool = False
    eaten: list[tuple[ObjectSpec, bool]] = field(default_factory=list)  # (food, eaten by the head)
    new_wall_hits: int = 0
    fell: bool = False


def limb_eats(limb_food_reward: str) -> bool:
    return limb_food_reward != "none"


def food_reward(food: ObjectSpec, by_head: bool, limb_food_reward: str) -> float:
    if by_head or limb_food_reward == "size":
        return food.food_value
    return LIMB_FLAT_REWARD[food.kind] if limb_food_reward == "flat" else 0.0


def step_reward(events: StepEvents, max_steps: int, ground_penalty: bool, limb_food_reward: str) -> dict[str, float]:
    """Reward terms of one step; their sum is the step's reward."""
    unit = 0.5 / max_steps
    return {
        "step": -unit,
        "ground": -unit if (events.head_on_floor or not ground_penalty) else 0.0,
        "food": sum(food_reward(food, by_head, limb_food_reward) for food, by_head in events.eaten),
        "wall": -1.0 * events.new_wall_hits,
        "fall": -1.0 if events.fell else 0.0,
        "shaping": 0.0,  # set by the env when episode.shaping > 0 (training only)
    }
