"""The level registry: configs/levels/L*.yaml joined to the generators in this package.

A level is a pure function of (difficulty, seed, parameters) that returns a LevelSpec.
"""
from __future__ import annotations

import functools
import importlib
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import numpy as np

from aaai.config import ConfigError, config_dir, read_yaml
from aaai.levels.params import DIFFICULTIES, resolve
from aaai.spec import AgentPose, LevelSpec

LEVEL_FILE_KEYS = ("id", "name", "title", "generator", "params")
SEED_LIMIT = 2**32  # seeds are integers in [0, 2**32)


@dataclass(frozen=True)
class Level:
    id: int
    name: str
    title: str
    generator: ModuleType
    params: dict
    source: str

    @property
    def label(self) -> str:
        return f"L{self.id}"


def _load_level(path) -> Level:
    data = read_yaml(path)
    for key in data:
        if key not in LEVEL_FILE_KEYS:
            raise ConfigError(f"{path.name}: key '{key}' does not exist; allowed: {', '.join(LEVEL_FILE_KEYS)}")
    for key in LEVEL_FILE_KEYS:
        if key not in data:
            raise ConfigError(f"{path.name}: key '{key}' is missing")
    return Level(data["id"], data["name"], data["title"], _generator(data["generator"], path.name),
                 data["params"], path.name)


def _generator(name: str, source: str) -> ModuleType:
    """The generator module aaai/levels/<name>.py named by a level file."""
    available = sorted(p.stem for p in Path(__file__).parent.glob("*.py") if not p.stem.startswith("_"))
    if name not in available or name in ("common", "params"):
        raise ConfigError(f"{source}: generator {name!r} does not exist; allowed: a module of aaai/levels/")
    return importlib.import_module(f"aaai.levels.{name}")


@functools.cache
def all_levels() -> dict[int, Level]:
    """Every level shipped in configs/levels/, by id."""
    found = [_load_level(path) for path in sorted((config_dir() / "levels").glob("L*.yaml"))]
    return {level.id: level for level in sorted(found, key=lambda level: level.id)}


def get_level(ref: int | str) -> Level:
    """A level by id (3), label ('L3') or name ('food_contact')."""
    levels = all_levels()
    for level in levels.values():
        if ref in (level.id, level.label, level.name, str(level.id)):
            return level
    allowed = ", ".join(f"{level.id} ({level.name})" for level in levels.values())
    raise ConfigError(f"level {ref!r} does not exist; allowed: {allowed}")


def check_difficulty(difficulty) -> int:
    if isinstance(difficulty, bool) or not isinstance(difficulty, (int, np.integer)) or difficulty not in DIFFICULTIES:
        raise ConfigError(f"difficulty: got {difficulty!r}; allowed: an integer from 0 to 10")
    return int(difficulty)


def check_seed(seed) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < SEED_LIMIT:
        raise ConfigError(f"seed: got {seed!r}; allowed: an integer from 0 to {SEED_LIMIT - 1}")
    return int(seed)


def episode_rngs(level_id: int, difficulty: int, seed: int) -> tuple[np.random.Generator, np.random.Generator]:
    """Two independent generators for an episode: one builds the level, one drives its moving parts."""
    spec_seq, motion_seq = np.random.SeedSequence([seed, level_id, difficulty]).spawn(2)
    return np.random.default_rng(spec_seq), np.random.default_rng(motion_seq)


def generate(level: int | str, difficulty: int, seed: int) -> LevelSpec:
    """The level spec for (level, difficulty, seed): the same inputs always give an equal spec."""
    lvl = get_level(level)
    difficulty, seed = check_difficulty(difficulty), check_seed(seed)
    params = resolve(lvl.params, difficulty, lvl.generator.PARAMETERS, lvl.source)
    rng, _ = episode_rngs(lvl.id, difficulty, seed)
    built = lvl.generator.generate(params, difficulty, rng)
    return LevelSpec(
        level=lvl.id,
        name=lvl.name,
        difficulty=difficulty,
        seed=seed,
        agent=AgentPose(*built.pop("agent")),
        objects=tuple(built.pop("objects")),
        max_food_reward=float(built.pop("max_food_reward")),
        **built,
    )
