"""Seed ranges. Training draws from TRAIN_SEEDS only; RESERVED_SEEDS are kept for evaluation.

The reserved evaluation set is a fixed list of K seeds per (level, difficulty): the first K
distinct draws of a generator seeded with (RESERVED_KEY, level, difficulty) from
RESERVED_SEEDS, so every user evaluates on the same episodes (`aaai seeds` prints them).
"""
from __future__ import annotations

import numpy as np

TRAIN_SEEDS = range(0, 1288490240)
RESERVED_SEEDS = range(1288490240, 1717986944)
OTHER_SEEDS = range(1717986944, 2**32)  # neither: seeds picked by hand
RESERVED_KEY = 20241121  # fixed forever: changing it changes every published score


def reserved_seeds(level: int, difficulty: int, count: int) -> list[int]:
    """The first ``count`` reserved seeds of a (level, difficulty) cell; a longer list extends a shorter one."""
    rng = np.random.default_rng([RESERVED_KEY, level, difficulty])
    seeds: list[int] = []
    while len(seeds) < count:
        seed = int(rng.integers(RESERVED_SEEDS.start, RESERVED_SEEDS.stop))
        if seed not in seeds:
            seeds.append(seed)
    return seeds


def seed_range(seed: int) -> range:
    """The range a seed belongs to (training, reserved or other). A level that builds another
    level (L6, L7) draws the inner seed from the outer seed's range, so that training never builds
    a level from a reserved seed and evaluation never from a training one."""
    for seeds in (TRAIN_SEEDS, RESERVED_SEEDS, OTHER_SEEDS):
        if seed in seeds:
            return seeds
    raise ValueError(f"seed: got {seed!r}; allowed: an integer from 0 to {OTHER_SEEDS.stop - 1}")


def training_seed(rng: np.random.Generator) -> int:
    """One training seed, drawn by the caller's generator."""
    return int(rng.integers(TRAIN_SEEDS.start, TRAIN_SEEDS.stop))
