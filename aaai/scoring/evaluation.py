"""`aaai eval`: score a policy on fixed seeds and write a CSV scoreboard, one row per episode.

This module is the scoring loop (:func:`score`) and its two plans, level cells (:func:`evaluate`)
and arena files (:func:`evaluate_arenas`). The parts it joins each live in a module of their own,
and their public names are importable from here too: the episode and its row
(:mod:`aaai.scoring.episodes`: ``run_episode``, ``outcome``), the resume plan
(:mod:`aaai.scoring.plan`: ``Cell``, ``cells_for``, ``seeds_for``, ``episode_plan``), the CSV file
(:mod:`aaai.scoring.scoreboard`: ``Scoreboard``, ``scored_episodes``, ``COLUMNS``), what a
scoreboard was scored with (:mod:`aaai.scoring.provenance`: ``policy_record``, ``check_record``,
``record_path``, ``arena_hashes``) and the summaries (:mod:`aaai.scoring.summaries`: ``summarise``,
``write_summary``).
"""

from __future__ import annotations

from contextlib import closing
from pathlib import Path
from typing import Callable, Generator

from aaai.config import Config, ConfigError, env_part
from aaai.env import AnimalAIEnv
from aaai.scoring.episodes import PASS_RATIO, SUCCESS_RATIO, outcome, run_episode
from aaai.scoring.plan import TRAIN_EVAL_KEY, Cell, Episode, cells_for, episode_plan, seeds_for
from aaai.scoring.policies import Policy, as_policy
from aaai.scoring.provenance import (
    arena_hashes,
    check_arena_hashes,
    check_record,
    env_record,
    policy_record,
    record_differences,
    record_path,
    scoring_record,
)
from aaai.scoring.runs import check_writable
from aaai.scoring.scoreboard import (
    COLUMNS,
    LEGACY_COLUMNS,
    Scoreboard,
    columns_of,
    scoreboard_lock,
    scored_episodes,
    write_error,
)
from aaai.scoring.summaries import summarise, summarise_arenas, summary_markdown, write_summary
from aaai.task.arena import load_arena

__all__ = [
    "COLUMNS",
    "LEGACY_COLUMNS",
    "PASS_RATIO",
    "SUCCESS_RATIO",
    "TRAIN_EVAL_KEY",
    "Cell",
    "Episode",
    "Scoreboard",
    "arena_hashes",
    "cells_for",
    "check_record",
    "columns_of",
    "env_record",
    "episode_plan",
    "evaluate",
    "evaluate_arenas",
    "outcome",
    "play_here",
    "policy_record",
    "record_differences",
    "record_path",
    "run_episode",
    "score",
    "scoreboard_lock",
    "scored_episodes",
    "scoring_record",
    "seeds_for",
    "summarise",
    "summarise_arenas",
    "summary_markdown",
    "write_error",
    "write_summary",
]


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
    record = check_record(output, scoring_record(policy, record, config))
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
    every seed before any episode runs: nothing is run from an invalid file. A ``record`` that holds
    each file's SHA-256 (``arena_sha256``, :func:`arena_hashes`) is kept with the scoreboard, and
    resuming it after a file has changed is refused, naming the file (:func:`check_arena_hashes`)."""
    check_arena_hashes(output, arenas, record)
    for arena in arenas:
        for seed in seeds:
            load_arena(arena, seed, body=config.agent.body)
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
