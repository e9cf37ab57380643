"""Seed ranges. Training draws from TRAIN_SEEDS only; RESERVED_SEEDS are kept for evaluation.

The reserved evaluation set is a fixed list of K seeds per (level, difficulty): the first K
distinct draws of a generator seeded with (RESERVED_KEY, level, difficulty) from
RESERVED_SEEDS, so every user evaluates on the same episodes (`aaai seeds` prints them).

A hidden test set: with a secret key (a key file, or the AAAI_SEED_KEY environment variable) the
list is drawn from a generator seeded with a hash of the key instead, so whoever holds the key can
hold back a set of reserved episodes for later evaluations or competitions. A scoreboard records
another hash of the key (``key_record``), from which the seeds cannot be recovered.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np

TRAIN_SEEDS = range(0, 1288490240)
RESERVED_SEEDS = range(1288490240, 1717986944)
OTHER_SEEDS = range(1717986944, 2**32)  # neither: seeds picked by hand
RESERVED_KEY = 20241121  # fixed forever: changing it changes every published score


SEED_KEY_VARIABLE = "AAAI_SEED_KEY"


def reserved_seeds(level: int, difficulty: int, count: int, key: str | None = None) -> list[int]:
    """The first ``count`` reserved seeds of a (level, difficulty) cell; a longer list extends a
    shorter one. With a secret ``key``, the hidden list that key stands for."""
    if key is None:
        rng = np.random.default_rng([RESERVED_KEY, level, difficulty])
    else:
        words = np.frombuffer(hashlib.sha256(b"aaai reserved seeds\0" + key.encode()).digest(), np.uint32)
        rng = np.random.default_rng([*map(int, words), level, difficulty])
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


def key_record(key: str | None) -> str:
    """What a scoreboard records of the key: "public", or a hash of the key that is not the one the
    seeds are drawn from (so the record gives the seeds away no more than the key's absence does)."""
    if key is None:
        return "public"
    return "sha256:" + hashlib.sha256(b"aaai key record\0" + key.encode()).hexdigest()


MAX_KEY_FILE_BYTES = 1 << 20  # a key is a line of text; a larger file is no key file


def read_seed_key(path: str | Path | None = None) -> str | None:
    """The secret key from a key file (its text, stripped) or else from AAAI_SEED_KEY; None if neither."""
    if path is not None:
        path = Path(path)
        if not path.is_file():
            raise ValueError(f"--seed-key-file: got {str(path)!r}; allowed: a readable file holding the key")
        if path.stat().st_size > MAX_KEY_FILE_BYTES:
            raise ValueError(
                f"--seed-key-file: {str(path)!r} is {path.stat().st_size:,} bytes; "
                f"allowed: a key file of at most {MAX_KEY_FILE_BYTES:,}"
            )
        try:
            key = path.read_text(errors="strict").strip()
        except UnicodeDecodeError as error:
            raise ValueError(
                f"--seed-key-file: {str(path)!r} is not text (byte {error.start} is not UTF-8); "
                "allowed: a file holding the key as text"
            ) from None
        source = f"--seed-key-file {str(path)!r}"
    else:
        variable = os.environ.get(SEED_KEY_VARIABLE)
        if variable is None:
            return None
        key, source = variable.strip(), SEED_KEY_VARIABLE
    if len(key) < 8:
        raise ValueError(f"{source}: the key is {len(key)} characters long; allowed: a key of at least 8 characters")
    return key
