"""The red team's attacks, a module a group (what they attack); ``register`` makes them all, in order."""

from __future__ import annotations

from . import (
    animalai,
    arena,
    cli_numbers,
    config,
    env_kwargs,
    file_flags,
    model_zip,
    play,
    replay,
    run_folders,
    scoreboard,
)
from .base import ATTACKS, Attack

GROUPS = [
    replay,
    config,
    env_kwargs,
    file_flags,
    run_folders,
    scoreboard,
    model_zip,
    animalai,
    arena,
    cli_numbers,
    play,
]


def register() -> list[Attack]:
    """Every group's attacks, once, in the order of ``GROUPS`` (the order of the CSV's rows)."""
    if not ATTACKS:
        for group in GROUPS:
            group.attacks()
    return ATTACKS
