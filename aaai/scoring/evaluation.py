"""`aaai eval`: score a policy on fixed seeds and write a CSV scoreboard, one row per episode.

An episode's ratio is return / max_reward, where max_reward is the best food reward that level
instance can give minus 0.5 (allowing for step costs). Outcome: failed (ratio < 0.8), passed
(0.8 <= ratio < 1) or succeeded (ratio >= 1), as in the original build.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
from contextlib import closing
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Generator

import numpy as np

from aaai.config import Config, ConfigError, env_part
from aaai.env import AnimalAIEnv
from aaai.files import Lock, hold, write_atomic
from aaai.levels import all_levels, get_level
from aaai.scoring.episodes import play
from aaai.scoring.policies import Policy, as_policy
from aaai.scoring.runs import check_writable
from aaai.task.arena import load_arena
from aaai.task.seeds import TRAIN_SEEDS, key_record, reserved_seeds

# "arena": the arena file's name (aaai.task.arena), empty for a generated level. A scoreboard written
# before that column existed (LEGACY_COLUMNS) is still read (its rows get arena "") and added to
# in its own columns.
LEGACY_COLUMNS = [
    "level",
    "level_name",
    "difficulty",
    "seed",
    "return",
    "max_reward",
    "ratio",
    "outcome",
    "steps",
    "max_steps",
    "food_eaten",
    "wall_hits",
    "fell",
    "wall_seconds",
]
COLUMNS = LEGACY_COLUMNS[:-1] + ["arena", "wall_seconds"]  # the timing stays last
PASS_RATIO, SUCCESS_RATIO = 0.8, 1.0
TRAIN_EVAL_KEY = 7  # seeds `--seeds train` picks: fixed draws from the training range


def outcome(ratio: float, episode_return: float | None = None, pass_mark: float | None = None) -> str:
    """failed, passed or succeeded. With an arena's own ``pass_mark`` (Animal-AI's passMark, as
    aaai.tools.animalai.passed reads it) the return at or above it passes instead of the 0.8 ratio."""
    if pass_mark is not None and episode_return is not None:
        if episode_return < pass_mark:
            return "failed"
        return "succeeded" if ratio >= SUCCESS_RATIO else "passed"
    if ratio >= SUCCESS_RATIO:
        return "succeeded"
    return "passed" if ratio >= PASS_RATIO else "failed"


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


# --- running --------------------------------------------------------------------------
@dataclass
class Cell:
    level: int
    difficulty: int
    seeds: list[int]


def run_episode(
    env: AnimalAIEnv, policy: Callable, level: int, difficulty: int, seed: int, arena: Path | None = None
) -> dict:
    """Plays one episode of the cell (or of the arena file, with the seed) to its end; its scoreboard row."""
    pass_mark = None
    options: dict[str, Any]
    if arena is None:
        options = {"level": level, "difficulty": difficulty}
    else:
        spec = load_arena(arena, seed)
        options, level, difficulty = {"spec": spec, "check": False}, spec.level, spec.difficulty  # checked on load
        pass_mark = (spec.extras or {}).get("pass_mark")
    result = play(env, policy, seed, options=options)
    total, info = result.episode_return, result.info
    ratio = total / info["max_reward"] if info["max_reward"] > 0 else math.nan
    return {
        "level": level,
        "level_name": info["level_name"],
        "difficulty": difficulty,
        "seed": seed,
        "return": round(total, 6),
        "max_reward": round(info["max_reward"], 6),
        "ratio": round(ratio, 6),
        "outcome": outcome(ratio, total, pass_mark),
        "steps": info["steps"],
        "max_steps": info["max_steps"],
        "food_eaten": info["food_eaten"],
        "wall_hits": info["wall_hits"],
        "fell": info["fell"],
        "arena": arena.name if arena is not None else "",
        "wall_seconds": round(result.wall_seconds, 3),
    }


class Scoreboard:
    """Appends rows to a scoreboard CSV, each durable (flushed and fsynced) before the next episode.

    Nothing is written before the first row: the record (``*_scored_with.json``) and, for a new
    file, the header appear with it, so an eval that fails before its first episode ends leaves no
    file behind. An OS error while writing (a full disk, a permission taken away, a folder where
    the file should be) is a ConfigError naming the file; the rows written before it stay, and the
    same command run again resumes after them.
    """

    def __init__(
        self,
        output: Path,
        record: dict,
        columns: list[str],
        rows: list[dict],
        on_episode: Callable[[dict], None] | None = None,
    ):
        self.output, self.record, self.columns, self.rows, self.on_episode = (
            Path(output),
            record,
            columns,
            rows,
            on_episode,
        )
        self.handle: io.TextIOWrapper[io.BufferedWriter] | None = None  # open from the first row on

    def _opened(self) -> io.TextIOWrapper[io.BufferedWriter]:
        """The file open for appending (opened, with the record beside it, at the first row)."""
        if self.handle is None:
            new = not self.output.exists() or self.output.stat().st_size == 0
            if new or not record_path(self.output).exists():
                write_atomic(record_path(self.output), json.dumps(self.record, indent=1, sort_keys=True) + "\n")
            self.handle = io.TextIOWrapper(open(self.output, "ab"), newline="")  # its buffer dropped on a failed write
            if new:
                csv.writer(self.handle).writerow(self.columns)
        return self.handle

    def append(self, row: dict) -> None:
        """Writes one episode's row and makes it durable before the next episode starts. A row
        that cannot be written whole is cut off again, so that the file ends with the last whole row."""
        durable = None
        try:
            handle = self._opened()
            durable = os.fstat(handle.fileno()).st_size
            csv.DictWriter(handle, fieldnames=self.columns, extrasaction="ignore").writerow(row)
            handle.flush()
            os.fsync(handle.fileno())
        except OSError as error:
            self._abandon(durable)
            raise ConfigError(write_error(self.output, error, len(self.rows))) from None
        self.rows.append({k: str(v) for k, v in row.items()})
        if self.on_episode:
            self.on_episode(row)

    def _abandon(self, durable: int | None) -> None:
        """After a failed write: drops what is still buffered (it must not reach the file later,
        mid-line) and cuts the file back to its whole rows."""
        if self.handle is None:
            return
        descriptor = self.handle.fileno()
        try:
            if durable is not None:
                os.ftruncate(descriptor, durable)
        except OSError:
            pass  # a torn last line is cut when the scoreboard is next read
        try:
            self.handle.buffer.raw.close()  # closed under the buffers: what they hold is discarded, not written
            self.handle.close()  # (a no-op once the file below is closed)
        except (OSError, ValueError):
            pass
        self.handle = None

    def close(self) -> None:
        if self.handle is not None:
            try:
                self.handle.close()
            except (OSError, ValueError):
                pass  # what could not be flushed was reported by append
            self.handle = None

    def __enter__(self) -> "Scoreboard":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def write_error(path: Path, error: OSError, kept: int) -> str:
    """The message for an OS error on a file an eval writes: the file, the cause, what stays."""
    where = getattr(error, "filename2", None) or getattr(error, "filename", None) or path  # a rename: its target
    cause = error.strerror or str(error) or type(error).__name__
    return (
        f"--out: cannot write {str(where)!r}: {cause}. The {kept} row(s) of {str(path)!r} written before "
        "stay; free the space or fix the permission, then run the same command again to resume"
    )


def scored_episodes(path: Path) -> list[dict]:
    """Rows already in a scoreboard; a torn last line (an interrupted write) is cut off."""
    if not path.exists():
        return []
    try:
        text = path.read_text()
    except UnicodeDecodeError as error:
        raise ConfigError(
            f"{str(path)!r} is not a scoreboard: byte {error.start} is not UTF-8 text; allowed: a CSV an eval wrote"
        ) from None
    if text and not text.strip():  # blank lines only: no header and no rows, so it starts afresh
        with open(path, "r+") as handle:
            handle.truncate(0)
        return []
    if text and not text.endswith("\n"):
        with open(path, "r+") as handle:
            handle.truncate(text.rfind("\n") + 1)
        text = text[: text.rfind("\n") + 1]
    try:
        rows = list(csv.DictReader(text.splitlines()))
    except csv.Error as error:
        raise ConfigError(f"{str(path)!r} is not a scoreboard ({error}); allowed: a CSV an eval wrote") from None
    whole = [row for row in rows if None not in row and None not in row.values()]
    if len(whole) < len(rows):  # a line torn mid-file (a write cut short, then appended to): played again
        lines = text.splitlines(keepends=True)
        write_atomic(path, lines[0] + "".join(line for line, row in zip(lines[1:], rows) if row in whole))
        rows = whole
    if rows and list(rows[0].keys()) == LEGACY_COLUMNS:
        rows = [{**row, "arena": ""} for row in rows]
    elif rows and list(rows[0].keys()) != COLUMNS:
        raise ConfigError(f"{str(path)!r} is not a scoreboard of this version (columns {list(rows[0].keys())})")
    for number, row in enumerate(rows, 2):
        _check_row(path, number, row)
    return rows


def _check_row(path: Path, number: int, row: dict) -> None:
    """A row of a scoreboard being continued holds what an eval writes: the level of a level this
    version has, whole numbers for difficulty, seed and steps, a number for the return."""
    for key, kind in (
        ("level", int),
        ("difficulty", int),
        ("seed", int),
        ("steps", int),
        ("return", float),
        ("ratio", float),
    ):
        try:
            kind(row[key])
        except (TypeError, ValueError):
            raise ConfigError(
                f"{str(path)!r} row {number}: {key} {row[key]!r} is not a number; allowed: rows an eval wrote "
                "(delete the row, and the eval plays its episode again)"
            ) from None
    if int(row["level"]) not in set(all_levels()):
        raise ConfigError(
            f"{str(path)!r} row {number}: level {row['level']!r} does not exist; allowed: rows an eval wrote "
            "(delete the row, and the eval plays its episode again)"
        )


def columns_of(path: Path) -> list[str]:
    """The columns to add rows to a scoreboard in: its own header's if it is an older scoreboard
    (without "arena"), else COLUMNS."""
    if path.exists():
        with open(path, newline="") as handle:
            header = next(csv.reader(handle), None)
        if header == LEGACY_COLUMNS:
            return LEGACY_COLUMNS
    return COLUMNS


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


def score(
    policy: Policy,
    output: Path,
    config: Config,
    plan: Callable[[list[dict]], list[Episode]],
    play: Callable[[list[Episode]], Generator[dict, None, None]],
    record: dict | None = None,
    on_episode: Callable[[dict], None] | None = None,
) -> list[dict]:
    """The scoring loop of every eval: refuses an output that cannot be written or that holds
    another policy's episodes, reads the rows already there, asks ``plan(rows)`` for the episodes
    still to play, and appends each row ``play(episodes)`` yields (:func:`play_here`: one after
    another in this process; :mod:`aaai.scoring.distributed`: as Ray tasks), flushed per episode.
    ``record`` (default: the policy on listed seeds) is what the scoreboard is scored with; with
    the environment's config, action mode and the package version added (:func:`scoring_record`)
    it is kept beside it. Returns every row of the scoreboard (those there before, then the new
    ones as they came), as strings. One eval at a time writes a scoreboard (:func:`scoreboard_lock`)."""
    output = Path(output)
    check_writable(output, "--out")
    output.parent.mkdir(parents=True, exist_ok=True)
    with scoreboard_lock(output):
        return _score(policy, output, config, plan, play, record, on_episode)


def scoreboard_lock(output: Path) -> Lock:
    """The lock on a scoreboard (``.NAME.lock`` beside it, holding the pid), held while an eval
    reads and adds to it: another eval of the same file refuses at once, naming the holder."""
    return hold(
        output.with_name(f".{output.name}.lock"),
        lambda pid: (
            f"--out: scoreboard {str(output)!r} is being written by "
            + (f"process {pid}" if pid else "another process")
            + "; allowed: one eval at a time per scoreboard (wait for it to end, or choose another --out)"
        ),
    )


def _score(
    policy: Policy,
    output: Path,
    config: Config,
    plan: Callable[[list[dict]], list[Episode]],
    play: Callable[[list[Episode]], Generator[dict, None, None]],
    record: dict | None,
    on_episode: Callable[[dict], None] | None,
) -> list[dict]:
    """:func:`score` with the scoreboard locked."""
    record = scoring_record(policy, record, config)
    check_record(output, record)
    rows = scored_episodes(output)
    episodes = plan(rows)
    played = play(episodes)
    with Scoreboard(output, record, columns_of(output), rows, on_episode) as board, closing(played):
        for row in played:
            board.append(row)
    return rows


def play_here(
    policy: Policy,
    config: Config,
    episodes: list[Episode],
    make_policy: Callable[[AnimalAIEnv], Callable] | None = None,
) -> Generator[dict, None, None]:
    """Plays ``episodes`` one after another in this process, on one environment without shaping
    (scores count the task's own reward), yielding each one's row. ``make_policy(env)`` (default:
    ``policy.build(env)``) makes the acting policy, e.g. a human's (aaai.tools.play) or a recorder."""
    env = AnimalAIEnv(config=env_part(config, shaping=0.0))
    try:
        acting = make_policy(env) if make_policy is not None else policy.build(env)
        for episode in episodes:
            yield run_episode(env, acting, *episode)
    finally:
        env.close()


def evaluate(
    policy: Policy | str,
    cells: list[Cell],
    output: Path,
    config: Config,
    on_episode: Callable[[dict], None] | None = None,
    record: dict | None = None,
    make_policy: Callable[[AnimalAIEnv], Callable] | None = None,
    trust: bool = False,
) -> list[dict]:
    """Plays every (cell, seed) not yet in ``output`` (:func:`episode_plan`) and appends its row
    (:func:`score`); resuming with another record is refused. ``policy``: a Policy, or a --policy
    string (resolved with ``trust``, --trust-model). ``make_policy(env)``: see :func:`play_here`."""
    policy = as_policy(policy, trust)
    return score(
        policy,
        output,
        config,
        lambda rows: episode_plan(cells, rows),
        lambda episodes: play_here(policy, config, episodes, make_policy),
        record,
        on_episode,
    )


def evaluate_arenas(
    policy: Policy | str,
    arenas: list[Path],
    seeds: list[int],
    output: Path,
    config: Config,
    on_episode: Callable[[dict], None] | None = None,
    record: dict | None = None,
    make_policy: Callable[[AnimalAIEnv], Callable] | None = None,
    trust: bool = False,
) -> list[dict]:
    """:func:`evaluate` for a battery of arena files: every (arena, seed) not yet in ``output``,
    one row each, its ``arena`` column the file's name. Every file is loaded (and so checked) for
    every seed before any episode runs: nothing is run from an invalid file."""
    for arena in arenas:
        for seed in seeds:
            load_arena(arena, seed)
    names = [arena.name for arena in arenas]
    if len(set(names)) != len(names):
        raise ConfigError(
            f"--arenas: two arena files share a name ({sorted(n for n in names if names.count(n) > 1)[0]}); "
            "allowed: distinct file names, which the scoreboard's arena column tells apart"
        )
    policy = as_policy(policy, trust)

    def plan(rows: list[dict]) -> list[Episode]:
        if rows and columns_of(output) != COLUMNS:
            raise ConfigError(
                f"--out: {str(output)!r} is an older scoreboard without an arena column; choose another --out"
            )
        done = {(r["arena"], int(r["seed"])) for r in rows}
        return [(0, 0, seed, arena) for arena in arenas for seed in seeds if (arena.name, seed) not in done]

    return score(
        policy,
        output,
        config,
        plan,
        lambda episodes: play_here(policy, config, episodes, make_policy),
        record,
        on_episode,
    )


def summarise_arenas(rows: list[dict], categories: dict[str, str | None]) -> list[dict]:
    """Per arena (by file name), per category (the arena file's ``category``, a level name; rows of
    arenas without one are "uncategorised") and overall: the columns of :func:`summarise`."""
    by_arena: dict[str, list[dict]] = {}
    by_category: dict[str, list[dict]] = {}
    for row in rows:
        by_arena.setdefault(f"arena {row['arena']}", []).append(row)
        by_category.setdefault(categories.get(row["arena"]) or "uncategorised", []).append(row)
    order = {level.name: level.id for level in all_levels().values()}
    groups = sorted(by_arena.items()) + [
        (f"category {get_level(name).label} {name}" if name in order else f"category {name}", group)
        for name, group in sorted(by_category.items(), key=lambda item: order.get(item[0], 10**6))
    ]
    return [_summary_row(name, group) for name, group in groups + [("overall", rows)] if group]


def _summary_row(name: str, group: list[dict]) -> dict:
    ratios = np.array([float(r["ratio"]) for r in group])
    outcomes = [r["outcome"] for r in group]
    return {
        "level": name,
        "episodes": len(group),
        "mean_return": float(np.mean([float(r["return"]) for r in group])),
        "mean_ratio": float(np.nanmean(ratios)) if np.isfinite(ratios).any() else math.nan,
        "passed_pct": 100.0 * sum(o != "failed" for o in outcomes) / len(group),
        "succeeded_pct": 100.0 * outcomes.count("succeeded") / len(group),
    }


# --- summary --------------------------------------------------------------------------
def summarise(rows: list[dict]) -> list[dict]:
    """Per level and overall: episodes, mean return, mean ratio, % passed or better, % succeeded."""
    groups: dict[str, list[dict]] = {}
    for row in rows:
        groups.setdefault(f"{get_level(int(row['level'])).label} {row['level_name']}", []).append(row)
    ordered = sorted(groups.items(), key=lambda item: int(item[1][0]["level"])) + [("overall", rows)]
    summary = []
    for name, group in ordered:
        if not group:
            continue
        summary.append(_summary_row(name, group))
    return summary


def summary_markdown(summary: list[dict]) -> str:
    lines = [
        "| level | episodes | mean return | mean ratio | passed or better | succeeded |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for s in summary:
        lines.append(
            f"| {s['level']} | {s['episodes']} | {s['mean_return']:.3f} | {s['mean_ratio']:.3f} | "
            f"{s['passed_pct']:.0f}% | {s['succeeded_pct']:.0f}% |"
        )
    return "\n".join(lines) + "\n"


def write_summary(summary: list[dict], output: Path) -> Path:
    path = output.with_name(output.stem + "_summary.md")
    write_atomic(path, summary_markdown(summary))
    return path


def cells_for(levels: list[int], difficulties: list[int], seeds: str, count: int, key: str | None = None) -> list[Cell]:
    for level in levels:
        get_level(level)
    return [Cell(level, d, seeds_for(seeds, level, d, count, key)) for level in levels for d in difficulties]


def policy_record(policy: Policy | str, seeds: str, key: str | None = None) -> dict:
    """What a scoreboard was scored with: the policy's record (its model file and hash, or its
    source's hash), the seeds and the seed key's record. An eval that resumes a scoreboard must match it."""
    return {**as_policy(policy).record, "seeds": seeds, "seed_key": key_record(key)}


def record_path(output: Path) -> Path:
    return output.with_name(output.stem + "_scored_with.json")


def env_record(config: Config) -> dict:
    """What a scoreboard records of the environment it was scored in: the whole environment config
    (the level and difficulty defaults aside: each row names its own), its digest, the action mode
    and the package's version."""
    from aaai import __version__

    part = {k: v for k, v in env_part(config, shaping=0.0).env_dict().items() if k not in ("level", "difficulty")}
    part = json.loads(json.dumps(part, sort_keys=True, default=str))  # as it reads back from the file
    digest = hashlib.sha256(json.dumps(part, sort_keys=True).encode()).hexdigest()
    return {
        "env_config": part,
        "env_config_sha256": digest,
        "action_mode": part.get("agent", {}).get("action_mode"),
        "aaai_version": __version__,
    }


def scoring_record(policy: Policy, record: dict | None, config: Config) -> dict:
    """The whole record of a scoreboard: the policy's (default: on listed seeds), the environment's
    and, for a policy whose actions are put on a grid, how they are computed (``numerics``)."""
    numerics = {"numerics": policy.numerics} if policy.numerics else {}
    return {**(record if record is not None else policy_record(policy, "list")), **env_record(config), **numerics}


def _flat(tree: Any, prefix: str = "") -> dict[str, Any]:
    if not isinstance(tree, dict):
        return {prefix: tree}
    flat: dict[str, Any] = {}
    for key, value in tree.items():
        flat.update(_flat(value, f"{prefix}.{key}" if prefix else str(key)))
    return flat


def record_differences(earlier: Any, record: dict) -> list[str]:
    """The keys in which two records differ, each with both values (dotted for nested keys)."""
    old, new = _flat(earlier if isinstance(earlier, dict) else {}), _flat(record)
    missing = object()
    return [
        f"{key}: {old.get(key, 'absent')!r} there, {new.get(key, 'absent')!r} now"
        for key in sorted(set(old) | set(new), key=str)
        if old.get(key, missing) != new.get(key, missing)
    ]


def _has_rows(output: Path) -> bool:
    try:
        with open(output, "rb") as handle:  # bytes: any file may be handed in as --out
            return sum(1 for _ in zip(range(2), handle)) > 1
    except FileNotFoundError:
        return False


def check_record(output: Path, record: dict) -> None:
    """Refuses to add to a scoreboard scored with anything else, naming each key that differs.

    The record itself is written with the scoreboard's first row (:class:`Scoreboard`); one beside
    a scoreboard that holds no row yet (an eval that failed before its first episode ended) does
    not count."""
    path = record_path(output)
    if not _has_rows(output):
        return
    if not path.exists():
        raise ConfigError(
            f"--out: {str(output)!r} holds episodes of an unknown policy (no {path.name}); "
            "choose another --out, or delete it to start again"
        )
    try:
        earlier = json.loads(path.read_text())
    except (OSError, ValueError):
        earlier = None
    if earlier != record:
        differences = record_differences(earlier, record) or ["its record cannot be read"]
        raise ConfigError(
            f"--out: {str(output)!r} holds episodes scored otherwise; refusing to add episodes that "
            f"differ in {len(differences)} key(s): "
            + "; ".join(differences)
            + f". Choose another --out, or delete {output.name} and {path.name} to start again"
        )
