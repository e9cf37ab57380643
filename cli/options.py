"""The click types of the command line's numbers: each refuses what the command cannot hold, before
any work, with click's one line naming the flag, the value and what is allowed."""

from __future__ import annotations

import math
import os
import stat
from pathlib import Path

import click

from aaai.config import RULES
from aaai.levels import SEED_LIMIT

SEED = click.IntRange(0, SEED_LIMIT - 1)  # what a level and Gymnasium's reset take
DIFFICULTY = click.IntRange(0, 10)
COUNT = click.IntRange(1, SEED_LIMIT)  # episodes or seeds in a row: each numbers a seed
WORKERS = click.IntRange(1, 256)  # processes or Ray CPUs (train.num_envs's bound)
MANY = 10**9  # the most steps, rounds or episodes a measurement or cap takes


def rule(key: str, low: int | None = None) -> click.IntRange:
    """The config key's own bounds (aaai.config.RULES), so that a flag and its key allow the same."""
    bounds = RULES[key]
    assert bounds.kind == "int" and bounds.low is not None and bounds.high is not None, key
    return click.IntRange(int(bounds.low if low is None else low), int(bounds.high))


class Finite(click.FloatRange):
    """A FloatRange that is also finite: FloatRange lets NaN through (it compares false with any
    bound), and infinity when a side is open."""

    def convert(self, value, param, ctx):
        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number; allowed: {self._describe_range()}", param, ctx)
        return number


class SeedList(click.ParamType):
    """--seeds: reserved, train, or a list of seeds like 1,2,3, each from 0 to 2**32 - 1. The text is
    kept as given (a scoreboard records it)."""

    name = "seeds"

    def convert(self, value, param, ctx):
        if value in ("reserved", "train"):
            return value
        allowed = f"reserved, train, or a list like 1,2,3 of seeds from 0 to {SEED_LIMIT - 1}"
        parts = str(value).split(",")
        if not all(part.strip().isdigit() and int(part) < SEED_LIMIT for part in parts):
            self.fail(f"got {value!r}; allowed: {allowed}", param, ctx)
        return value


class Output(click.Path):
    """An output's path (click.Path): refused if it is a device or other special file (/dev/null:
    the files written beside it would land in /dev), or if its parent is a file. ``what`` names what is
    allowed where click's own file and folder checks are left to the command (default: from them)."""

    def __init__(self, *args, what: str | None = None, **kwargs):
        super().__init__(*args, **kwargs)
        self.what = what

    def convert(self, value, param, ctx):
        path = super().convert(value, param, ctx)
        where = Path(os.fsdecode(path))
        if where.exists() and not (where.is_file() or where.is_dir()):
            mode = os.stat(where).st_mode
            kind = "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "not a regular file or folder"
            self.fail(f"got {value!r}, which is {kind}; allowed: a {self._kind()} path", param, ctx)
        parent = next((p for p in where.absolute().parents if p.exists()), None)
        if parent is not None and not parent.is_dir():
            self.fail(f"got {value!r}, but {str(parent)!r} is a file; allowed: a path inside a folder", param, ctx)
        return path

    def _kind(self) -> str:
        if self.what:
            return self.what
        return "folder" if not self.file_okay else "file" if not self.dir_okay else "file or folder"
