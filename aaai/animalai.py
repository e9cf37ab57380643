"""Animal-AI arena files (``!ArenaConfig``) as aaai arena files: ``aaai import-animalai``."""
from __future__ import annotations

from aaai.evaluation import PASS_RATIO
from aaai.spec import LevelSpec

STEP_ALLOWANCE = 0.5  # the scoreboard's max reward is the food's best minus this (aaai.evaluation)


def passed(episode_return: float, spec: LevelSpec) -> bool:
    """Did an episode of this level pass? At or above the arena's pass mark (``extras["pass_mark"]``)
    when it has one, else the scoreboard's rule (return / max reward >= PASS_RATIO)."""
    mark = spec.extras.get("pass_mark")
    if mark is not None:
        return episode_return >= mark
    best = spec.max_food_reward - STEP_ALLOWANCE
    return best > 0 and episode_return / best >= PASS_RATIO
