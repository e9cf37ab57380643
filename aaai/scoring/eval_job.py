"""`aaai eval` as one call: a policy scored on levels or on a battery of arena files, with its progress.

:func:`score_policy` resolves the ``--policy`` string, builds the config, plans the episodes, scores
them (here or on Ray), and summarises the rows; the command line only parses its flags and prints.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from aaai.config import Config, ConfigError
from aaai.jobs import Display, Progress, quietly
from aaai.scoring.evaluation import (
    Episode,
    arena_hashes,
    cells_for,
    evaluate,
    evaluate_arenas,
    play_here,
    policy_record,
    score,
    summarise,
    summarise_arenas,
    write_summary,
)
from aaai.scoring.plan import Cell
from aaai.scoring.policies import Policy, resolve
from aaai.scoring.provenance import ARENA_HASHES, unhashed_arenas


class ScoreboardError(OSError):
    """The scoreboard (or a file beside it) could not be written midway: one line naming the file and
    the cause. The rows written so far stay."""


@dataclass
class EvalResult:
    """What :func:`score_policy` scored: the rows, their summary and the scoreboard's path."""

    rows: list[dict]
    summary: list[dict]
    output: Path

    def write_summary(self) -> Path:
        """Writes the summary beside the scoreboard (``<scoreboard>_summary.md``); its path."""
        return write_summary(self.summary, self.output)


def with_action_mode(config: Config, action_mode: str | None) -> Config:
    """``config`` scored in ``action_mode`` (unchanged for None). A model trained in another mode
    is refused when it is loaded."""
    if action_mode is not None:
        config = config.replace(action_mode=action_mode)
    return config


def check_options(
    arenas: Any, levels: Any, difficulties: Any, seed_key_file: Any, backend: str, save_replays: Any
) -> None:
    """Options that cannot go together, refused before any work (ConfigError naming them): with
    ``--arenas`` (arena files, each its own level) the options that choose levels, a seed key or Ray;
    ``--save-replays`` but on the local backend."""
    if arenas is not None:
        clashes = [
            name
            for name, value in (
                ("--levels", levels),
                ("--difficulty", difficulties),
                ("--seed-key-file", seed_key_file),
            )
            if value is not None
        ]
        if backend != "local":
            clashes.append("--backend ray")
        if clashes:
            raise ConfigError(f"--arenas: {', '.join(clashes)} cannot be used with it (an arena file is its own level)")
    elif save_replays is not None and backend != "local":
        raise ConfigError("--save-replays: only with --backend local")


def score_policy(
    policy: str,
    *,
    seeds: str = "reserved",
    levels: list[int] | None = None,
    difficulties: list[int] | None = None,
    seeds_per_cell: int | None = None,
    config_path: str | None = None,
    output: str | Path | None = None,
    seed_key_file: str | Path | None = None,
    arenas: str | Path | None = None,
    backend: str = "local",
    address: str | None = None,
    workers: int = 2,
    action_mode: str | None = None,
    trust_model: bool = False,
    save_replays: str | Path | None = None,
    progress_every: float | None = None,
    display: Display = quietly,
    battery: list[Episode] | None = None,
    warn: Callable[[str], None] = print,
) -> EvalResult:
    """Scores ``policy`` (a ``--policy`` string) as ``aaai eval`` does, and gives back the rows and
    their summary (:meth:`EvalResult.write_summary` writes it).

    With ``arenas`` (a folder of arena files or one file), every file on seeds 0..K-1 or the
    ``seeds`` list, summarised per arena and per category; else the ``levels`` x ``difficulties``
    cells (default: the run's or config's curriculum) on ``seeds`` (reserved, train or a list
    '1,2,3'; reserved: the hidden list of the key in ``seed_key_file`` or AAAI_SEED_KEY, if given).
    K is ``seeds_per_cell`` (default eval.seeds_per_cell). With ``battery`` (a study's trials,
    ``aaai eval --study``), exactly those episodes, each once, summarised per level. The scoreboard goes to ``output``
    (default scoreboard_<seeds>.csv in the run folder, or here). ``display`` shows the progress (an
    :class:`aaai.jobs.Progress` counting episodes, a line every ``progress_every`` seconds when it
    writes lines). The scoreboard of ``arenas`` records each file's SHA-256; resuming it after a
    file has changed is refused, and resuming one whose record holds none (an older one) is ``warn``-ed
    about (a line: a changed file cannot be detected).

    Raises ConfigError (InUse: another process writes the scoreboard) or FileNotFoundError for an
    input that is not allowed, :class:`ScoreboardError` for a file that could not be written,
    ImportError for a missing extra.
    """
    check_options(arenas, levels, difficulties, seed_key_file, backend, save_replays)
    try:
        key = None if arenas is not None else read_key(seed_key_file)
        chosen = resolve(policy, trust_model)
        run_folder = Path(chosen.run) if chosen.run else None
        config = with_action_mode(chosen.config(config_path), action_mode)
        count = seeds_per_cell or config.eval.seeds_per_cell
        if battery is not None:
            output = Path(output) if output else (run_folder or Path(".")) / "scoreboard_study.csv"
            arena_files = [e[3] for e in battery if len(e) > 3]
            record = {**policy_record(chosen, "study"), "battery": [[*e[:3], *map(str, e[3:])] for e in battery]}
            report = Progress(len(battery), label="scoring", unit="episodes", every=progress_every)
            with display(report) as update:
                hooks = replay_hooks(save_replays, chosen, _counting(report, update), arena_files)
                rows = score(
                    chosen,
                    output,
                    config,
                    lambda rows: battery_plan(battery, rows),
                    lambda episodes: play_here(chosen, config, episodes, hooks.get("make_policy")),
                    record,
                    hooks["on_episode"],
                )
            return EvalResult(rows, summarise(rows), output)
        if arenas is not None:
            return _score_arenas(
                chosen, arenas, seeds, count, run_folder, output, config, save_replays, progress_every, display, warn
            )
        cells = _level_cells(config, levels, difficulties, seeds, count, key)
        label = seeds if seeds in ("reserved", "train") else "list"
        output = Path(output) if output else (run_folder or Path(".")) / f"scoreboard_{label}.csv"
        record = policy_record(chosen, seeds, key)
        report = Progress(
            sum(len(cell.seeds) for cell in cells), label="scoring", unit="episodes", every=progress_every
        )
        with display(report) as update:
            on_episode = _counting(report, update)
            if backend == "ray":
                from aaai.scoring.distributed import evaluate_on_ray

                rows = evaluate_on_ray(
                    chosen,
                    cells,
                    output,
                    config,
                    address=address,
                    workers=workers,
                    on_episode=on_episode,
                    record=record,
                )
            else:
                rows = evaluate(
                    chosen, cells, output, config, record=record, **replay_hooks(save_replays, chosen, on_episode)
                )
        return EvalResult(rows, summarise(rows), output)
    except FileNotFoundError:
        raise
    except ScoreboardError:
        raise
    except OSError as error:  # an output that became unwritable midway (its rows so far stay)
        raise ScoreboardError(f"{str(error.filename or output)!r}: {error.strerror or error}") from error


def _level_cells(
    config: Config,
    levels: list[int] | None,
    difficulties: list[int] | None,
    seeds: str,
    count: int,
    key: str | None = None,
) -> list[Cell]:
    """The ``levels`` x ``difficulties`` cells (default: the config's curriculum), K = ``count`` seeds each."""
    level_list = levels if levels is not None else list(config.curriculum.levels)
    difficulty_list = difficulties if difficulties is not None else list(config.curriculum.difficulties)
    return cells_for(level_list, difficulty_list, seeds, count, key)


@dataclass
class CurveResult:
    """What :func:`score_checkpoints` scored: the curve's rows (step, seconds, episodes, passed,
    pass_pct) and its path."""

    rows: list[dict]
    output: Path


def score_checkpoints(
    policy: str,
    *,
    levels: list[int] | None = None,
    difficulties: list[int] | None = None,
    seeds_per_cell: int | None = None,
    config_path: str | None = None,
    every: int = 0,
    trust_model: bool = False,
    progress_every: float | None = None,
    display: Display = quietly,
    echo: Callable[[str], None] = print,
) -> CurveResult:
    """``aaai eval --policy RUN --checkpoints``: each checkpoint of the run (every one, or the first
    at each multiple of ``every`` steps) and its final model scored on the same reserved episodes,
    the ``levels`` x ``difficulties`` cells (default the run's curriculum) with K seeds each; writes
    the run's curve.csv and curve/reserved_<step>.csv (:func:`aaai.scoring.curves.score_curve`).
    ConfigError for a policy that is not a run folder."""
    from aaai.scoring.curves import curve_points, read_curve, score_curve, scored_points
    from aaai.scoring.runs import RunFolder

    chosen = resolve(policy, trust_model)
    if chosen.run is None or not Path(policy).is_dir():
        raise ConfigError(
            f"--checkpoints: --policy got {policy!r}; allowed: a run folder (with checkpoints/ or final/)"
        )
    config = chosen.config(config_path)
    cells = _level_cells(config, levels, difficulties, "reserved", seeds_per_cell or config.eval.seeds_per_cell)
    run = RunFolder(chosen.run)
    episodes = sum(len(cell.seeds) for cell in cells)
    scored = scored_points(run.path / "curve.csv", episodes)
    to_score = [step for step, _ in curve_points(run, every) if step not in scored]
    report = Progress(episodes * len(to_score), label="scoring", unit="episodes", every=progress_every)
    with display(report) as update:
        path = score_curve(
            run, cells, config, echo, every=every, trust=trust_model, on_episode=_counting(report, update)
        )
    return CurveResult(list(read_curve(path).values()), path)


def _score_arenas(
    chosen: Policy,
    arenas: str | Path,
    seeds: str,
    count: int,
    run_folder: Path | None,
    output: str | Path | None,
    config: Config,
    save_replays: str | Path | None,
    progress_every: float | None,
    display: Display,
    warn: Callable[[str], None],
) -> EvalResult:
    """``aaai eval --arenas``: every arena file of the battery on seeds 0..K-1 (or a --seeds list); the
    record names the folder (or file) as given and each file's SHA-256 (``arena_sha256``); each row names
    its seed, so more seeds (a larger -k) continue the same scoreboard."""
    from aaai.task.arena import arena_files, arena_meta

    if seeds == "reserved":  # the default: an arena's seeds are 0..K-1
        seed_list = list(range(count))
    elif seeds == "train":
        raise ConfigError("--seeds: got 'train' with --arenas; allowed: a list like 1,2,3 (default 0..K-1)")
    else:
        try:
            seed_list = [int(part) for part in seeds.split(",")]
        except ValueError:
            raise ConfigError(f"--seeds: got {seeds!r}; allowed: a list like 1,2,3 (default 0..K-1)") from None
    files = arena_files(arenas)
    categories = {path.name: arena_meta(path)["category"] for path in files}
    output = Path(output) if output else (run_folder or Path(".")) / "scoreboard_arenas.csv"
    record = {**policy_record(chosen, "list"), "arenas": str(arenas), ARENA_HASHES: arena_hashes(files)}
    note = unhashed_arenas(output)
    if note:
        warn(note)
    report = Progress(len(files) * len(seed_list), label="scoring", unit="episodes", every=progress_every)
    try:
        with display(report) as update:
            hooks = replay_hooks(save_replays, chosen, _counting(report, update), files)
            rows = evaluate_arenas(chosen, files, seed_list, output, config, record=record, **hooks)
    except OSError as error:
        if isinstance(error, FileNotFoundError):
            raise
        raise ScoreboardError(f"{str(error.filename or output)!r}: {error.strerror or error}") from error
    return EvalResult(rows, summarise_arenas(rows, categories), output)


def battery_plan(battery: list[Episode], rows: list[dict]) -> list[Episode]:
    """The episodes of a study's battery (``aaai eval --study``) not yet in the scoreboard's ``rows``,
    each once, in the battery's order: (level, difficulty, seed) or (0, 0, seed, arena file)."""
    done = {(r["arena"], 0, 0, int(r["seed"])) if r.get("arena") else ("", *_ints(r)) for r in rows}
    plan = []
    for episode in battery:
        key = (episode[3].name, 0, 0, episode[2]) if len(episode) > 3 else ("", *episode[:3])
        if key not in done:
            plan.append(episode)
            done.add(key)
    return plan


def _ints(row: dict) -> tuple[int, int, int]:
    return int(row["level"]), int(row["difficulty"]), int(row["seed"])


def read_key(seed_key_file: str | Path | None) -> str | None:
    """The secret seed key of ``seed_key_file``, else of AAAI_SEED_KEY; None if neither (ConfigError for
    a file that is not one)."""
    from aaai.levels.seeds import read_seed_key

    try:
        return read_seed_key(seed_key_file)
    except ValueError as error:
        raise ConfigError(str(error)) from None


def _counting(report: Progress, update: Callable[[int], None]) -> Callable[[dict], None]:
    """The ``on_episode`` of a scoring loop: each scored row counted in ``report`` (passed or not, its
    steps) and shown."""

    def on_episode(row: dict) -> None:
        report.add_episodes([row["outcome"] != "failed"], steps=int(row["steps"]))
        update(1)

    return on_episode


def replay_hooks(
    folder: str | Path | None, policy: Policy, on_episode: Callable[[dict], None], arenas: Any = ()
) -> dict[str, Any]:
    """``aaai eval --save-replays``: the keywords that make ``evaluate`` record the policy and
    write each scored episode's replay into ``folder`` (just ``on_episode`` without a folder)."""
    if folder is None:
        return {"on_episode": on_episode}
    from aaai.scoring.replays import ReplaySaver
    from aaai.scoring.runs import check_writable

    check_writable(Path(folder), "--save-replays", folder=True)
    saver = ReplaySaver(
        folder,
        policy.name,
        policy.build,
        arenas={Path(a).name: Path(a) for a in arenas},
        on_episode=on_episode,
    )
    return {"on_episode": saver.on_episode, "make_policy": saver.make_policy}
