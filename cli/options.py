"""What the commands share: the click types of their numbers and paths, the level and range parsers, help texts.

Each type refuses what the command cannot hold, before any work, with click's one line naming the
flag, the value and what is allowed."""

from __future__ import annotations

import math
import os
import stat
from pathlib import Path

import click

from aaai.config import RULES, ConfigError, describe_ids, parse_int_set
from aaai.levels import SEED_LIMIT, describe_levels, get_level, level_ids

SEED = click.IntRange(0, SEED_LIMIT - 1)  # what a level and Gymnasium's reset take
DIFFICULTY = click.IntRange(0, 10)
COUNT = click.IntRange(1, SEED_LIMIT)  # episodes or seeds in a row: each numbers a seed
WORKERS = click.IntRange(1, 256)  # processes or Ray CPUs (train.num_envs's bound)
MANY = 10**9  # the most steps, rounds or episodes a measurement or cap takes


def rule(key: str, low: int | None = None) -> click.IntRange | click.FloatRange:
    """The config key's own bounds (aaai.config.RULES), so that a flag and its key allow the same."""
    bounds = RULES[key]
    assert bounds.kind in ("int", "float") and bounds.low is not None and bounds.high is not None, key
    if bounds.kind == "float":
        return Finite(float(bounds.low if low is None else low), float(bounds.high))
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


POLICY_HELP = (
    "random, reference (the privileged reference controller), search (the reference knowing only the "
    "food the rays have shown it), search_strict (the same, knowing the walls too only as the rays show "
    "them), search_thorough (the search that looks on for food it has not seen before eating a green), "
    "gait (the example trot), "
    "a model .zip, a run folder or module:callable"
)
TRUST_HELP = (
    "Load a model file with stable-baselines3's own loader, which unpickles it and so runs any code in "
    "it (default: rebuilt without unpickling; docs, Scoring agents you did not write). Only for files "
    "you trust."
)


PROGRESS_HELP = (
    "Seconds between progress lines when the output is not a terminal (piped, nohup); in a terminal a progress bar."
)


class Seconds(click.FloatRange):
    """A number of seconds, at least ``min``: not NaN or infinity (which FloatRange lets through)."""

    name = "seconds"

    def convert(self, value, param, ctx):
        import math

        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"got {value!r}; allowed: a finite number of seconds, {self.min} or more", param, ctx)
        return number


def parse_range(text: str, name: str, low: int, high: int) -> list[int]:
    """'0-3,5' -> [0, 1, 2, 3, 5], each checked to lie in low..high."""
    try:
        return parse_int_set(text, name, low, high)
    except ConfigError as error:
        raise click.BadParameter(str(error).split(": ", 1)[1], param_hint=name) from None


def parse_levels(text: str | None, name: str = "--levels") -> list[int]:
    """'0-3,5', 'L2b,L3' or 'food_contact' -> those level ids, each a registered level (by id, label
    or name; ranges by id); None or 'all' -> every registered level."""
    known = level_ids()
    if text is None or text.strip() == "all":
        return known
    allowed = (
        f"all, or a list of levels by id ({describe_ids(known)}), label or name ({describe_levels()}), "
        "with id ranges like '0-3,5'"
    )
    ids, numeric = [], []
    for part in (part.strip() for part in text.split(",")):
        try:
            ids.append(get_level(part).id)  # an id, label or name (a custom level's may start with a digit)
        except ConfigError:
            if not part[:1].isdigit():  # not an id range either
                refusal = f"got {text!r}: no level {part!r}; allowed: {allowed}"
                raise click.BadParameter(refusal, param_hint=name) from None
            numeric.append(part)
    if numeric:
        try:
            ids += parse_int_set(",".join(numeric), name, 0, max(known))
        except ConfigError:
            raise click.BadParameter(f"got {text!r}; allowed: {allowed}", param_hint=name) from None
    missing = [level for level in ids if level not in known]
    if missing:
        raise click.BadParameter(
            f"got {text!r}, and level {missing[0]} does not exist; allowed: {allowed}", param_hint=name
        )
    return sorted(set(ids))
