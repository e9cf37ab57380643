"""A study file: the YAML that names a study's battery, practice, order, breaks, time limit, texts
and what a participant may see.

It is read with :mod:`aaai.safe_yaml` (data, never code) and checked key by key; a problem is one
:class:`aaai.errors.ConfigError` naming the file, the line, the key, the value and what is allowed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aaai.errors import ConfigError
from aaai.levels import SEED_LIMIT, check_difficulty, get_level
from aaai.safe_yaml import load_with_nodes
from aaai.task.arena_reader import Source

ORDERS = ("fixed", "random", "counterbalanced")
SHOW_KEYS = ("map", "coordinates", "seed", "returns")
TEXT_KEYS = ("consent", "instructions", "completion")
KEYS = (
    "name",
    "battery",
    "practice",
    "order",
    "breaks_every",
    "time_limit",
    "texts",
    "show",
    "camera_resolution",
    "store",
)
TRIAL_KEYS = ("level", "difficulty", "seed", "arena")
MAX_TRIALS = 1000
MAX_TEXT_CHARS = 5000
MAX_TIME_LIMIT = 600.0
STUDY_NAME = r"[A-Za-z0-9_-]{1,60}"
SERVER_SCHEMES = ("postgresql", "postgresql+psycopg")  # the store on a PostgreSQL server (psycopg 3)

DEFAULT_TEXTS = {
    "consent": "This is a short study about finding food in a small 3D world. It takes about ten minutes. "
    "Taking part is voluntary: you may stop at any time by closing this page. We record only your key "
    "presses and what happens in the game, under a code, never your name or address.",
    "instructions": "You are an animal in a small arena. Find the food (the green ball) and touch it. "
    "Walk with the arrow keys (or W, A, S, D). Some food lies low: hold C (or Shift) to crouch and reach it. "
    "Press Space to start each round.",
    "completion": "Thank you! You have finished the study. You can close this page now.",
}


@dataclass(frozen=True)
class Trial:
    """One trial: a level cell and seed, or an arena file (its path, resolved) and seed."""

    level: int | None
    difficulty: int | None
    seed: int
    arena: Path | None = None

    def label(self) -> str:
        if self.arena is not None:
            return f"{self.arena.name} s{self.seed}"
        return f"{get_level(self.level or 0).label} d{self.difficulty} s{self.seed}"


@dataclass(frozen=True)
class Study:
    """A study file's contents, checked."""

    path: Path
    name: str
    battery: list[Trial]
    practice: list[Trial] = field(default_factory=list)
    order: str = "fixed"
    breaks_every: int = 0  # a break after every N battery trials (0: none)
    time_limit: float | None = None  # seconds per trial (None: each level's own)
    texts: dict[str, str] = field(default_factory=lambda: dict(DEFAULT_TEXTS))
    show: dict[str, bool] = field(default_factory=lambda: dict.fromkeys(SHOW_KEYS, False))
    camera_resolution: int = 84
    store: Path | str = Path("study.sqlite")  # a SQLite file, or a PostgreSQL server's address


def _allowed_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _trials(source: Source, data: Any, key: str, base: Path, required: bool) -> list[Trial]:
    if data is None and not required:
        return []
    if not isinstance(data, list) or (required and not data) or len(data) > MAX_TRIALS:
        raise source.error(
            (key,),
            f"got {_shown(data)}; allowed: a list of 1 to {MAX_TRIALS} trials, each "
            "{level: L, difficulty: D, seed: S} or {arena: FILE, seed: S}",
        )
    trials = []
    for index, item in enumerate(data):
        where = (key, index)
        if not isinstance(item, dict):
            raise source.error(where, f"got {_shown(item)}; allowed: a mapping with {', '.join(TRIAL_KEYS)}")
        for name in item:
            if name not in TRIAL_KEYS:
                raise source.error(where + (name,), f"unknown key {name!r}; allowed: {', '.join(TRIAL_KEYS)}")
        seed = item.get("seed", 0)
        if not _allowed_int(seed) or not 0 <= seed < SEED_LIMIT:
            raise source.error(where + ("seed",), f"got {_shown(seed)}; allowed: a whole number 0 to {SEED_LIMIT - 1}")
        if "arena" in item:
            if "level" in item or "difficulty" in item:
                raise source.error(where, "an arena trial names no level or difficulty (the arena file is its level)")
            arena = item["arena"]
            path = base / arena if isinstance(arena, str) else None
            if path is None or not path.is_file():
                raise source.error(
                    where + ("arena",), f"got {_shown(arena)}; allowed: an arena file, relative to the study file"
                )
            from aaai.task.arena import load_arena

            try:
                load_arena(path, seed)
            except ConfigError as error:
                raise source.error(where + ("arena",), str(error)) from None
            trials.append(Trial(None, None, seed, path.resolve()))
            continue
        if "level" not in item:
            raise source.error(where, "a trial needs 'level' (or 'arena'); allowed: a level id, label or name")
        try:
            level = get_level(item["level"]).id
        except ConfigError as error:
            raise source.error(where + ("level",), str(error)) from None
        difficulty = item.get("difficulty", 0)
        try:
            difficulty = check_difficulty(difficulty)
        except ConfigError:
            raise source.error(
                where + ("difficulty",), f"got {_shown(item.get('difficulty'))}; allowed: a whole number 0 to 10"
            ) from None
        trials.append(Trial(level, difficulty, seed))
    return trials


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _server_url(source: Source, url: str) -> str:
    """``store:`` a PostgreSQL address, checked: its scheme, a host and a database, and no password
    (a study file is shared: the password comes from PGPASSWORD or ~/.pgpass)."""
    from urllib.parse import urlsplit

    try:
        parts = urlsplit(url)
        parts.port  # noqa: B018 - a port that is not a number raises
    except ValueError:
        parts = None
    if parts is None or parts.scheme not in SERVER_SCHEMES or not parts.hostname or parts.path.strip("/") == "":
        raise source.error(
            ("store",),
            f"got {_shown(url)}; allowed: a file name, or postgresql+psycopg://USER@HOST[:PORT]/DATABASE",
        )
    if parts.password is not None:
        raise source.error(
            ("store",),
            "a password in the study file's address; allowed: the address without it (the password comes "
            "from the PGPASSWORD variable or ~/.pgpass)",
        )
    return url


def load_study(path: str | Path) -> Study:
    """The study file at ``path``, checked; ConfigError names the line, the key, the value and what is allowed."""
    import re

    path = Path(path)
    data, node = load_with_nodes(path, "study file")
    if not isinstance(data, dict) or node is None:
        raise ConfigError(f"study file {str(path)!r}: got {_shown(data)}; allowed: a mapping of {', '.join(KEYS)}")
    source = Source(path, node)
    for key in data:
        if key not in KEYS:
            raise source.error((key,), f"unknown key {key!r}; allowed: {', '.join(KEYS)}")
    name = data.get("name")
    if not isinstance(name, str) or not re.fullmatch(STUDY_NAME, name):
        raise source.error(("name",), f"got {_shown(name)}; allowed: 1 to 60 letters, digits, '-' or '_'")
    base = path.parent
    battery = _trials(source, data.get("battery"), "battery", base, required=True)
    practice = _trials(source, data.get("practice"), "practice", base, required=False)
    order = data.get("order", "fixed")
    if order not in ORDERS:
        raise source.error(("order",), f"got {_shown(order)}; allowed: {', '.join(ORDERS)}")
    breaks = data.get("breaks_every", 0)
    if not _allowed_int(breaks) or breaks < 0:
        raise source.error(
            ("breaks_every",), f"got {_shown(breaks)}; allowed: 0 (no breaks) or a whole number of trials"
        )
    limit = data.get("time_limit")
    if limit is not None and (
        isinstance(limit, bool)
        or not isinstance(limit, (int, float))
        or not math.isfinite(limit)
        or not 0 < limit <= MAX_TIME_LIMIT
    ):
        raise source.error(
            ("time_limit",), f"got {_shown(limit)}; allowed: seconds per trial, over 0 and at most {MAX_TIME_LIMIT:g}"
        )
    texts = dict(DEFAULT_TEXTS)
    given = data.get("texts", {}) or {}
    if not isinstance(given, dict):
        raise source.error(("texts",), f"got {_shown(given)}; allowed: a mapping of {', '.join(TEXT_KEYS)}")
    for key, text in given.items():
        if key not in TEXT_KEYS:
            raise source.error(("texts", key), f"unknown key {key!r}; allowed: {', '.join(TEXT_KEYS)}")
        if not isinstance(text, str) or not text.strip() or len(text) > MAX_TEXT_CHARS:
            raise source.error(("texts", key), f"got {_shown(text)}; allowed: text of 1 to {MAX_TEXT_CHARS} characters")
        texts[key] = text.strip()
    show = dict.fromkeys(SHOW_KEYS, False)
    wanted = data.get("show", {}) or {}
    if not isinstance(wanted, dict):
        raise source.error(("show",), f"got {_shown(wanted)}; allowed: a mapping of {', '.join(SHOW_KEYS)}")
    for key, value in wanted.items():
        if key not in SHOW_KEYS:
            raise source.error(("show", key), f"unknown key {key!r}; allowed: {', '.join(SHOW_KEYS)}")
        if not isinstance(value, bool):
            raise source.error(("show", key), f"got {_shown(value)}; allowed: true or false")
        show[key] = value
    resolution = data.get("camera_resolution", 84)
    if not _allowed_int(resolution) or not 8 <= resolution <= 512:
        raise source.error(("camera_resolution",), f"got {_shown(resolution)}; allowed: a whole number 8 to 512")
    store = data.get("store", f"{path.stem}.sqlite")
    if isinstance(store, str) and "://" in store:
        store_at: Path | str = _server_url(source, store)
    elif not isinstance(store, str) or not store or store.endswith(("/", "\\")):
        raise source.error(
            ("store",),
            f"got {_shown(store)}; allowed: a file name (relative to the study file) or a "
            "postgresql+psycopg://USER@HOST[:PORT]/DATABASE address",
        )
    else:
        store_at = base / store
    return Study(
        path=path,
        name=name,
        battery=battery,
        practice=practice,
        order=order,
        breaks_every=breaks,
        time_limit=float(limit) if limit is not None else None,
        texts=texts,
        show=show,
        camera_resolution=resolution,
        store=store_at,
    )


__all__ = ["ORDERS", "SHOW_KEYS", "TEXT_KEYS", "Study", "Trial", "load_study"]
