"""The level registry: level files (configs/levels/L*.yaml) joined to their generators.

A level is a pure function of (difficulty, seed, parameters) that returns a LevelSpec. Every
generated spec is checked (aaai.levels.validate); one that fails is generated again from a generator
derived from the same (seed, level, difficulty) and the attempt number, so the result is still a
pure function of the inputs.

Levels are plug-ins: a level file names its generator, a module of this package ("obstacles") or
any importable module ("mylab.levels.spiral"); folders listed in the environment variable
AAAI_LEVELS (separated as PATH is) add their L*.yaml files to the shipped ones. A generator module
has PARAMETERS (the names its level file's params must give) and ``generate(params, rng)``
returning the spec's fields; with ``WRAPS_OTHER_LEVELS = True`` it is ``generate(params, rng,
inner)`` and ``inner(rng)`` makes it a random level that wraps no other.

Beside the generators: the checks every spec passes (aaai.levels.validate) and the seed ranges
(aaai.levels.seeds); this package imports nothing of aaai.task, which sits above it.
"""

from __future__ import annotations

import functools
import importlib
import os
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from aaai.config import ConfigError, config_dir, read_yaml, use_level_ids
from aaai.levels import validate
from aaai.levels.common import PlacementError
from aaai.levels.params import DIFFICULTIES, resolve
from aaai.levels.seeds import seed_range
from aaai.spec import AgentPose, LevelSpec

LEVEL_FILE_KEYS = ("id", "name", "title", "generator", "params", "time_limit", "label")
OPTIONAL_KEYS = ("label",)  # label: how the level is shown, default "L<id>" (L2b has id 12)
SEED_LIMIT = 2**32  # seeds are integers in [0, 2**32)
MAX_ATTEMPTS = 50  # generations of one (level, difficulty, seed) before it is an error
HELPERS = ("common", "params", "seeds", "validate")  # modules of this package that are no generator


class InvalidLevelError(RuntimeError):
    """No valid level could be generated; the message names the level, difficulty and seed."""


@dataclass(frozen=True)
class Level:
    id: int
    name: str
    title: str
    generator: ModuleType
    params: dict
    source: str
    label: str
    time_limit: Any  # seconds: a number, 11 numbers or an expression in d, as a parameter

    @property
    def wraps(self) -> bool:
        """Does this level wrap a random other level (L6, L7)?"""
        return bool(getattr(self.generator, "WRAPS_OTHER_LEVELS", False))

    def time_limit_at(self, difficulty: int) -> float:
        """The episode's time limit (seconds of simulated time) at this difficulty."""
        return float(resolve({"time_limit": self.time_limit}, difficulty, ("time_limit",), self.source)["time_limit"])


LONGEST_TIME_LIMIT = 200.0  # seconds: a level's longest episode at any difficulty


def _load_level(path) -> Level:
    data = read_yaml(path, "level file")
    for key in data:
        if key not in LEVEL_FILE_KEYS:
            raise ConfigError(f"{path.name}: key '{key}' does not exist; allowed: {', '.join(LEVEL_FILE_KEYS)}")
    for key in LEVEL_FILE_KEYS:
        if key not in data and key not in OPTIONAL_KEYS:
            raise ConfigError(f"{path.name}: key '{key}' is missing")
    label = data.get("label", f"L{data['id']}")
    level = Level(
        data["id"],
        data["name"],
        data["title"],
        _generator(data["generator"], path.name),
        data["params"],
        path.name,
        label,
        data["time_limit"],
    )
    for difficulty in DIFFICULTIES:
        if not 0.2 <= level.time_limit_at(difficulty) <= LONGEST_TIME_LIMIT:
            raise ConfigError(
                f"{path.name}: key 'time_limit': got {level.time_limit_at(difficulty)!r} at difficulty "
                f"{difficulty}; allowed: 0.2 to {LONGEST_TIME_LIMIT:g} seconds"
            )
    return level


def _generator(name: str, source: str) -> ModuleType:
    """The generator module a level file names: aaai/levels/<name>.py, or a dotted module path."""
    ours = sorted(p.stem for p in Path(__file__).parent.glob("*.py") if not p.stem.startswith("_"))
    if name in HELPERS:
        name = ""
    try:
        module = importlib.import_module(f"aaai.levels.{name}" if name in ours else name)
    except (ImportError, ValueError, TypeError) as error:
        raise ConfigError(
            f"{source}: generator {name!r} cannot be imported ({error}); allowed: a module of "
            f"aaai/levels/ ({', '.join(n for n in ours if n not in HELPERS)}) or an "
            "importable module path"
        ) from None
    if not callable(getattr(module, "generate", None)) or not hasattr(module, "PARAMETERS"):
        raise ConfigError(f"{source}: generator {name!r} needs PARAMETERS and a generate() function")
    return module


def level_folders() -> list[Path]:
    """configs/levels/ and every folder in AAAI_LEVELS."""
    extra = [Path(part) for part in os.environ.get("AAAI_LEVELS", "").split(os.pathsep) if part]
    for folder in extra:
        if not folder.is_dir():
            raise ConfigError(
                f"AAAI_LEVELS: got {str(folder)!r}, which is not a folder; allowed: folders of L*.yaml files"
            )
    return [config_dir() / "levels", *extra]


@functools.cache
def _levels(folders: tuple[Path, ...]) -> dict[int, Level]:
    found: dict[int, Level] = {}
    for folder in folders:
        for path in sorted(folder.glob("L*.yaml")):
            level = _load_level(path)
            clash = found.get(level.id)
            if clash is not None:
                raise ConfigError(
                    f"{path}: level id {level.id} is taken by {clash.source} ({clash.name}); "
                    "allowed: an id no other level file has"
                )
            found[level.id] = level
    return dict(sorted(found.items()))


def all_levels() -> dict[int, Level]:
    """Every registered level, by id: the shipped ones and those of AAAI_LEVELS's folders."""
    return _levels(tuple(level_folders()))


def level_ids() -> list[int]:
    return list(all_levels())


use_level_ids(level_ids)  # config files and keywords name levels by these ids


def get_level(ref: int | str) -> Level:
    """A level by id (3), label ('L3') or name ('food_contact')."""
    levels = all_levels()
    for level in levels.values():
        if ref in (level.id, level.label, level.name, str(level.id)):
            return level
    raise ConfigError(f"level {ref!r} does not exist; allowed: {describe_levels()}")


def describe_levels() -> str:
    """Every registered level as '0 (L0 food_contact), 1 (L1 food_retrieval), ...'."""
    return ", ".join(f"{level.id} ({level.label} {level.name})" for level in all_levels().values())


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


def attempt_rng(level_id: int, difficulty: int, seed: int, attempt: int) -> np.random.Generator:
    """The generator that builds a level: the episode's for the first attempt, derived ones after."""
    if attempt == 0:
        return episode_rngs(level_id, difficulty, seed)[0]
    return np.random.default_rng(np.random.SeedSequence([seed, level_id, difficulty, attempt]))


def generate(level: int | str, difficulty: int, seed: int) -> LevelSpec:
    """The level spec for (level, difficulty, seed): the same inputs always give an equal spec.

    A spec that fails aaai.levels.validate.check is generated again (its ``regenerated`` counts the
    failed attempts); after MAX_ATTEMPTS it is an InvalidLevelError.
    """
    lvl = get_level(level)
    difficulty, seed = check_difficulty(difficulty), check_seed(seed)
    params = resolve(lvl.params, difficulty, lvl.generator.PARAMETERS, lvl.source)
    problem = ""
    for attempt in range(MAX_ATTEMPTS):
        try:
            rng = attempt_rng(lvl.id, difficulty, seed, attempt)
            if lvl.wraps:  # the inner seed stays in the outer seed's range
                built = lvl.generator.generate(
                    params, rng, inner=functools.partial(other_level, seeds=seed_range(seed))
                )
            else:
                built = lvl.generator.generate(params, rng)
        except PlacementError as error:
            problem = str(error)
            continue
        built.setdefault("time_limit", lvl.time_limit_at(difficulty))
        spec = _assemble(lvl, difficulty, seed, built, attempt)
        problems = validate.check(spec)
        if not problems:
            return spec
        problem = problems[0]
    raise InvalidLevelError(
        f"level {lvl.label} ({lvl.name}) difficulty {difficulty} seed {seed}: no valid level "
        f"in {MAX_ATTEMPTS} attempts; last problem: {problem}"
    )


def _assemble(lvl: Level, difficulty: int, seed: int, built: dict, attempt: int) -> LevelSpec:
    extras = dict(built.pop("extras", {}))
    return LevelSpec(
        level=lvl.id,
        name=lvl.name,
        difficulty=difficulty,
        seed=seed,
        agent=AgentPose(*built.pop("agent")),
        objects=tuple(built.pop("objects")),
        max_food_reward=float(built.pop("max_food_reward")),
        extras=extras,
        regenerated=attempt,
        **built,
    )


def other_level(rng: np.random.Generator, seeds: range) -> LevelSpec:
    """A random level that wraps no other, and cell (for L6, L7): the spec of an rng-drawn
    (level, difficulty, seed).

    The inner seed comes from rng, within ``seeds`` (the outer seed's range: aaai.levels.seeds.seed_range),
    so the result is a pure function of the outer level's seed and a reserved seed builds only
    from reserved seeds.
    """
    choices = [level.id for level in all_levels().values() if not level.wraps]
    level_id = int(rng.choice(choices))
    difficulty = int(rng.integers(DIFFICULTIES.start, DIFFICULTIES.stop))
    return generate(level_id, difficulty, int(rng.integers(seeds.start, seeds.stop)))
