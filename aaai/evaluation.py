"""`aaai eval`: score a policy on fixed seeds and write a CSV scoreboard, one row per episode.

An episode's ratio is return / max_reward, where max_reward is the best food reward that level
instance can give minus 0.5 (allowing for step costs). Outcome: failed (ratio < 0.8), passed
(0.8 <= ratio < 1) or succeeded (ratio >= 1), as in the original build.
"""
from __future__ import annotations

import csv
import hashlib
import importlib
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from aaai.config import ConfigError, env_part, load_config
from aaai.gait import SineGait
from aaai.env import AnimalAIEnv
from aaai.episodes import play
from aaai.files import write_atomic
from aaai.arena import load_arena
from aaai.levels import all_levels, get_level
from aaai.rllib_learner import rllib_checkpoint, run_backend
from aaai.runs import RunFolder, model_problem, check_writable
from aaai.seeds import TRAIN_SEEDS, key_record, reserved_seeds

# "arena": the arena file's name (aaai.arena), empty for a generated level. A scoreboard written
# before that column existed (LEGACY_COLUMNS) is still read (its rows get arena "") and added to
# in its own columns.
LEGACY_COLUMNS = ["level", "level_name", "difficulty", "seed", "return", "max_reward", "ratio", "outcome", "steps",
                  "max_steps", "food_eaten", "wall_hits", "fell", "wall_seconds"]
COLUMNS = LEGACY_COLUMNS[:-1] + ["arena", "wall_seconds"]  # the timing stays last
PASS_RATIO, SUCCESS_RATIO = 0.8, 1.0
TRAIN_EVAL_KEY = 7  # seeds `--seeds train` picks: fixed draws from the training range


def outcome(ratio: float) -> str:
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


# --- policies -------------------------------------------------------------------------
class RandomPolicy:
    """Uniform random actions, seeded per episode so that a scoreboard repeats exactly."""

    def __init__(self, env: AnimalAIEnv):
        self.space = env.action_space

    def reset(self, seed: int) -> None:
        self.space.seed(seed)

    def __call__(self, observation):
        return self.space.sample()


class ModelPolicy:
    """A stable-baselines3 PPO model, acting deterministically."""

    def __init__(self, path: Path):
        from stable_baselines3 import PPO

        try:
            self.model = PPO.load(path, device="cpu")
        except Exception as error:  # noqa: BLE001 - any failure inside the archive is the file's fault
            raise ConfigError(f"--policy: model file {str(path)!r} cannot be loaded by stable-baselines3: "
                              f"{type(error).__name__}: {error}") from None

    def reset(self, seed: int) -> None:
        pass

    def __call__(self, observation):
        action, _ = self.model.predict(observation, deterministic=True)
        return action


def model_path(policy: str) -> Path | None:
    """The model file a --policy names: a .zip, or a run folder's newest saved model (final/ when
    it is the newest). A damaged model is refused, never swapped for an older one."""
    path = Path(policy)
    if path.suffix == ".zip":
        if not path.is_file():
            raise ConfigError(f"--policy: model file {policy!r} does not exist")
        problem = model_problem(path)
        if problem:
            raise ConfigError(f"--policy: model file {policy!r} cannot be loaded: {problem}")
        return path
    if path.is_dir():
        run = RunFolder(path)
        if run.read_config()["train"]["agent"] == "random" or run_backend(path) == "rllib":
            return None  # a run of the random agent (scored with the random policy), or an RLlib run
        newest = run.latest_checkpoint()
        if newest is None:
            raise ConfigError(f"--policy: run folder {policy!r} holds no model (final/ or checkpoints/*/model.zip)")
        problem = model_problem(newest / "model.zip")
        if problem:
            older = next((f for f in run.saved()[1:] if model_problem(f / "model.zip") is None), None)
            hint = f"; to score an older one, pass --policy {older / 'model.zip'}" if older else ""
            raise ConfigError(f"--policy: the newest model of run {policy!r} ({newest.relative_to(path)}) cannot be "
                              f"loaded: {problem}{hint}")
        return newest / "model.zip"
    return None
def load_policy(policy: str, env: AnimalAIEnv) -> Callable:
    """'random', 'reference', 'gait', a model .zip, a run folder, or 'module:callable' called with the env to make the policy."""
    if policy == "random":
        return RandomPolicy(env)
    if policy == "reference":
        from aaai.reference import ReferenceController

        return ReferenceController(env)
    if policy == "gait":
        return SineGait.for_env(env)
    if Path(policy).is_dir() and run_backend(policy) == "rllib":
        from aaai.rllib_learner import RLlibPolicy

        return RLlibPolicy(policy, env)
    path = model_path(policy)
    if path is not None:
        return ModelPolicy(path)
    if Path(policy).is_dir():
        return RandomPolicy(env)
    return policy_factory(policy)(env)


def policy_factory(policy: str) -> Callable:
    """The callable a 'module:callable' policy names (called with the env to make the policy)."""
    module_name, _, attribute = policy.partition(":")
    if not attribute:
        raise ConfigError(f"--policy: got {policy!r}; allowed: random, reference, gait, a model .zip, a run folder, module:callable")
    try:
        target: Any = importlib.import_module(module_name)
        for part in attribute.split("."):
            target = getattr(target, part)
    except (ImportError, AttributeError) as error:
        raise ConfigError(f"--policy: cannot load {policy!r}: {error}") from None
    return target


# --- running --------------------------------------------------------------------------
@dataclass
class Cell:
    level: int
    difficulty: int
    seeds: list[int]


def run_episode(env: AnimalAIEnv, policy: Callable, level: int, difficulty: int, seed: int,
                arena: Path | None = None) -> dict:
    """Plays one episode of the cell (or of the arena file, with the seed) to its end; its scoreboard row."""
    if arena is None:
        options = {"level": level, "difficulty": difficulty}
    else:
        spec = load_arena(arena, seed)
        options, level, difficulty = {"spec": spec, "check": False}, spec.level, spec.difficulty  # checked on load
    result = play(env, policy, seed, options=options)
    total, info = result.episode_return, result.info
    ratio = total / info["max_reward"] if info["max_reward"] > 0 else math.nan
    return {
        "level": level, "level_name": info["level_name"], "difficulty": difficulty, "seed": seed,
        "return": round(total, 6), "max_reward": round(info["max_reward"], 6), "ratio": round(ratio, 6),
        "outcome": outcome(ratio), "steps": info["steps"], "max_steps": info["max_steps"],
        "food_eaten": info["food_eaten"],
        "wall_hits": info["wall_hits"], "fell": info["fell"],
        "arena": arena.name if arena is not None else "", "wall_seconds": round(result.wall_seconds, 3),
    }


def _append(writer: csv.DictWriter, handle, rows: list[dict], row: dict, on_episode) -> None:
    """Writes one episode's row and makes it durable before the next episode starts."""
    writer.writerow(row)
    handle.flush()
    os.fsync(handle.fileno())
    rows.append({k: str(v) for k, v in row.items()})
    if on_episode:
        on_episode(row)


def scored_episodes(path: Path) -> list[dict]:
    """Rows already in a scoreboard; a torn last line (an interrupted write) is cut off."""
    if not path.exists():
        return []
    text = path.read_text()
    if text and not text.endswith("\n"):
        with open(path, "r+") as handle:
            handle.truncate(text.rfind("\n") + 1)
        text = text[: text.rfind("\n") + 1]
    rows = list(csv.DictReader(text.splitlines()))
    if rows and list(rows[0].keys()) == LEGACY_COLUMNS:
        return [{**row, "arena": ""} for row in rows]
    if rows and list(rows[0].keys()) != COLUMNS:
        raise ConfigError(f"{str(path)!r} is not a scoreboard of this version (columns {list(rows[0].keys())})")
    return rows


def columns_of(path: Path) -> list[str]:
    """The columns to add rows to a scoreboard in: its own header's if it is an older scoreboard
    (without "arena"), else COLUMNS."""
    if path.exists():
        with open(path, newline="") as handle:
            header = next(csv.reader(handle), None)
        if header == LEGACY_COLUMNS:
            return LEGACY_COLUMNS
    return COLUMNS


def evaluate(policy_name: str, cells: list[Cell], output: Path, config: dict,
             on_episode: Callable[[dict], None] | None = None, record: dict | None = None) -> list[dict]:
    """Plays every (cell, seed) not yet in ``output`` and appends its row, flushed per episode.
    ``record`` (default: the policy on listed seeds) is what the scoreboard is scored with; it is
    kept beside it, and resuming with a different one is refused."""
    check_writable(output, "--out")
    output.parent.mkdir(parents=True, exist_ok=True)
    check_record(output, record if record is not None else policy_record(policy_name, "list"))
    rows = scored_episodes(output)
    done = {(int(r["level"]), int(r["difficulty"]), int(r["seed"])) for r in rows if not r["arena"]}
    env = AnimalAIEnv(config=env_part(config, shaping=0.0))  # scores count the task's own reward
    try:
        policy = load_policy(policy_name, env)
        new_file = not output.exists() or output.stat().st_size == 0
        with open(output, "a", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=columns_of(output), extrasaction="ignore")
            if new_file:
                writer.writeheader()
            for cell in cells:
                for seed in cell.seeds:
                    if (cell.level, cell.difficulty, seed) in done:
                        continue
                    row = run_episode(env, policy, cell.level, cell.difficulty, seed)
                    _append(writer, handle, rows, row, on_episode)
    finally:
        env.close()
    return rows


def evaluate_arenas(policy_name: str, arenas: list[Path], seeds: list[int], output: Path, config: dict,
                    on_episode: Callable[[dict], None] | None = None, record: dict | None = None) -> list[dict]:
    """:func:`evaluate` for a battery of arena files: every (arena, seed) not yet in ``output``,
    one row each, its ``arena`` column the file's name. Every file is loaded (and so checked) for
    every seed before any episode runs: nothing is run from an invalid file."""
    for arena in arenas:
        for seed in seeds:
            load_arena(arena, seed)
    names = [arena.name for arena in arenas]
    if len(set(names)) != len(names):
        raise ConfigError(f"--arenas: two arena files share a name ({sorted(n for n in names if names.count(n) > 1)[0]}); "
                          "allowed: distinct file names, which the scoreboard's arena column tells apart")
    check_writable(output, "--out")
    output.parent.mkdir(parents=True, exist_ok=True)
    check_record(output, record if record is not None else policy_record(policy_name, "list"))
    rows = scored_episodes(output)
    if rows and columns_of(output) != COLUMNS:
        raise ConfigError(f"--out: {str(output)!r} is an older scoreboard without an arena column; choose another --out")
    done = {(r["arena"], int(r["seed"])) for r in rows}
    env = AnimalAIEnv(config=env_part(config, shaping=0.0))
    try:
        policy = load_policy(policy_name, env)
        new_file = not output.exists() or output.stat().st_size == 0
        with open(output, "a", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=COLUMNS)
            if new_file:
                writer.writeheader()
            for arena in arenas:
                for seed in seeds:
                    if (arena.name, seed) in done:
                        continue
                    row = run_episode(env, policy, 0, 0, seed, arena=arena)
                    _append(writer, handle, rows, row, on_episode)
    finally:
        env.close()
    return rows


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
        for name, group in sorted(by_category.items(), key=lambda item: order.get(item[0], 10**6))]
    return [_summary_row(name, group) for name, group in groups + [("overall", rows)] if group]


def _summary_row(name: str, group: list[dict]) -> dict:
    ratios = np.array([float(r["ratio"]) for r in group])
    outcomes = [r["outcome"] for r in group]
    return {
        "level": name, "episodes": len(group),
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
        ratios = np.array([float(r["ratio"]) for r in group])
        outcomes = [r["outcome"] for r in group]
        summary.append({
            "level": name, "episodes": len(group),
            "mean_return": float(np.mean([float(r["return"]) for r in group])),
            "mean_ratio": float(np.nanmean(ratios)) if np.isfinite(ratios).any() else math.nan,
            "passed_pct": 100.0 * sum(o != "failed" for o in outcomes) / len(group),
            "succeeded_pct": 100.0 * outcomes.count("succeeded") / len(group),
        })
    return summary


def summary_markdown(summary: list[dict]) -> str:
    lines = ["| level | episodes | mean return | mean ratio | passed or better | succeeded |",
             "|---|---:|---:|---:|---:|---:|"]
    for s in summary:
        lines.append(f"| {s['level']} | {s['episodes']} | {s['mean_return']:.3f} | {s['mean_ratio']:.3f} | "
                     f"{s['passed_pct']:.0f}% | {s['succeeded_pct']:.0f}% |")
    return "\n".join(lines) + "\n"


def write_summary(summary: list[dict], output: Path) -> Path:
    path = output.with_name(output.stem + "_summary.md")
    write_atomic(path, summary_markdown(summary))
    return path


def cells_for(levels: list[int], difficulties: list[int], seeds: str, count: int, key: str | None = None) -> list[Cell]:
    for level in levels:
        get_level(level)
    return [Cell(level, d, seeds_for(seeds, level, d, count, key)) for level in levels for d in difficulties]


def policy_config(policy: str, config_path: str | None = None) -> dict:
    """The config a policy is scored with: ``config_path`` if given, else a run's own (the senses
    it was trained with), else the defaults."""
    if config_path or not Path(policy).is_dir():
        return load_config(config_path)
    return load_config(RunFolder(Path(policy)).read_config())


def policy_record(policy: str, seeds: str, key: str | None = None) -> dict:
    """What a scoreboard was scored with: the policy (and its model file's hash), the seeds and the
    seed key's record. An eval that resumes a scoreboard must match it."""
    record = {"policy": policy, "seeds": seeds, "seed_key": key_record(key)}
    path = None if policy in ("random", "reference", "gait") or ":" in policy else model_path(policy)
    if path is not None:
        record["model"] = str(path)
        record["model_sha256"] = hashlib.sha256(path.read_bytes()).hexdigest()
    elif Path(policy).is_dir() and run_backend(policy) == "rllib":
        checkpoint = rllib_checkpoint(policy)
        digest = hashlib.sha256()
        for file in sorted(f for f in checkpoint.rglob("*") if f.is_file()):
            digest.update(str(file.relative_to(checkpoint)).encode() + file.read_bytes())
        record["model"], record["model_sha256"] = str(checkpoint), digest.hexdigest()
    return record


def record_path(output: Path) -> Path:
    return output.with_name(output.stem + "_scored_with.json")


def check_record(output: Path, record: dict) -> None:
    """Writes the record beside a new scoreboard; refuses to add to one scored with anything else."""
    path = record_path(output)
    if path.exists():
        try:
            earlier = json.loads(path.read_text())
        except (OSError, ValueError):
            earlier = None
        if earlier != record:
            raise ConfigError(f"--out: {str(output)!r} holds episodes scored with {earlier}; refusing to add episodes "
                              f"of {record}: choose another --out, or delete both files to start again")
    elif output.exists() and output.stat().st_size > 0:
        raise ConfigError(f"--out: {str(output)!r} holds episodes of an unknown policy (no {path.name}); "
                          "choose another --out, or delete it to start again")
    else:
        write_atomic(path, json.dumps(record, indent=1, sort_keys=True) + "\n")
