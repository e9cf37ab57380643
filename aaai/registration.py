"""Gymnasium ids: aaai/AnimalAI-v0 (any level, chosen by keyword) and one id per level."""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, Any

import gymnasium as gym

if TYPE_CHECKING:
    from aaai.env import AnimalAIEnv
    from aaai.levels import Level

ENTRY_POINT = "aaai.env:AnimalAIEnv"


def level_env_id(level: Level) -> str:
    camel = "".join(part.capitalize() for part in level.name.split("_"))
    return f"aaai/{level.label}-{camel}-v0"


class LevelEnvMaker(functools.partial):
    """``make_level_env`` bound to one level, with the metadata gym.make reads from an entry point."""

    metadata: dict[str, Any] = {}


def register_envs() -> None:
    from aaai.env import AnimalAIEnv
    from aaai.levels import all_levels

    if "aaai/AnimalAI-v0" not in gym.registry:
        gym.register("aaai/AnimalAI-v0", entry_point=ENTRY_POINT)
    for level in all_levels().values():
        env_id = level_env_id(level)
        if env_id not in gym.registry:
            maker = LevelEnvMaker(make_level_env, level.id)
            maker.metadata = AnimalAIEnv.metadata  # gym.make reads the render modes from the entry point
            gym.register(env_id, entry_point=maker, kwargs={"level": level.id})


def make_level_env(id_level: int, **kwargs: Any) -> AnimalAIEnv:
    """The environment of a level's own id: ``level=`` may name that level (by id, label or name),
    not another one, which would silently make the id a lie."""
    from aaai.config import ConfigError
    from aaai.env import AnimalAIEnv
    from aaai.levels import get_level

    level = kwargs.pop("level", None)
    if level is not None and get_level(level).id != id_level:
        own = get_level(id_level)
        raise ConfigError(
            f"gym.make: got level={level!r} for {level_env_id(own)}; allowed: {own.label} (or leave "
            "level out), or aaai/AnimalAI-v0 with level= for any level"
        )
    return AnimalAIEnv(level=id_level, **kwargs)
