"""Gymnasium ids: aaai/AnimalAI-v0 (any level, chosen by keyword) and one id per level."""

from __future__ import annotations

import gymnasium as gym

ENTRY_POINT = "aaai.env:AnimalAIEnv"


def level_env_id(level) -> str:
    camel = "".join(part.capitalize() for part in level.name.split("_"))
    return f"aaai/{level.label}-{camel}-v0"


def register_envs() -> None:
    from aaai.levels import all_levels

    if "aaai/AnimalAI-v0" not in gym.registry:
        gym.register("aaai/AnimalAI-v0", entry_point=ENTRY_POINT)
    for level in all_levels().values():
        env_id = level_env_id(level)
        if env_id not in gym.registry:
            gym.register(env_id, entry_point=ENTRY_POINT, kwargs={"level": level.id})
