"""The resume plan of an eval: the cells (level, difficulty, seeds) it scores and, given the rows a
scoreboard already holds, the episodes still to play, each once, in cell and seed order."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aaai.config import ConfigError
from aaai.levels import get_level
from aaai.levels.seeds import TRAIN_SEEDS, reserved_seeds

TRAIN_EVAL_KEY = 7  # seeds `--seeds train` picks: fixed draws from the training range


def seeds_for(mode: str, level: int, difficulty: int, count: int, key: str | None = None) -> list[int]:
    """'reserved' (the hidden list of ``key`` if given), 'train' (fixed draws from the training
    range) or an explicit list '1,2,3'."""
    if key is not None and mode != "reserved":
        raise ConfigError(f"--seeds: got {mode!r} with a seed key; allowed: a seed key only with --seeds reserved")
    if mode == "reserved":
        return reserved_seeds(level, difficulty, count, key)
    if mode == "train":
        rng = np.random.default_rng([TRAIN_EVAL_KEY, level, difficulty])
        return [int(s) for s in rng.choice(TRAIN_SEEDS.stop, size=count, replace=False)]
    try:
        return [int(part) for part in mode.split(",")]
    except ValueError:
        raise ConfigError(f"--seeds: got {mode!r}; allowed: reserved, train or a list like 1,2,3") from None


@dataclass
class Cell:
    level: int
    difficulty: int
    seeds: list[int]


def episode_plan(cells: list[Cell], rows: list[dict]) -> list[tuple[int, int, int]]:
    """The (level, difficulty, seed) episodes still to play, in cell and seed order: each once,
    and none already scored in ``rows`` (a resumed scoreboard's level rows). Both backends play this."""
    done = {(int(r["level"]), int(r["difficulty"]), int(r["seed"])) for r in rows if not r.get("arena")}
    plan = []
    for cell in cells:
        for seed in cell.seeds:
            key = (int(cell.level), int(cell.difficulty), int(seed))
            if key not in done:
                plan.append(key)
                done.add(key)
    return plan


Episode = tuple  # (level, difficulty, seed), or (level, difficulty, seed, arena file): run_episode's arguments


def cells_for(levels: list[int], difficulties: list[int], seeds: str, count: int, key: str | None = None) -> list[Cell]:
    for level in levels:
        get_level(level)
    return [Cell(level, d, seeds_for(seeds, level, d, count, key)) for level in levels for d in difficulties]
