"""`aaai experiment curricula` (``make curricula``): the samplers compared on one budget, and `aaai plot`.

Every sampler (aaai.train.curriculum) trains PPO on the same config, cells and budget, once per
training seed. Every run is then scored on the reserved seeds of its cells (K per cell) and on
seeds it trained on (per cell, the last K distinct seeds it played): the difference is its
generalisation gap. The folder (default experiments/curricula/) gets:

  experiment.yaml          what was run: samplers, seeds, budget, cells, the base config
  <sampler>-seed<N>/       each run's folder (aaai.scoring.runs) with scoreboard_reserved.csv and
                           scoreboard_trained.csv (models, checkpoints and TensorBoard logs are
                           not committed: .gitignore)
  runs.csv                 one row per run scored so far: pass rates on reserved and trained seeds, the gap
  table.csv, table.md      per sampler: mean and standard deviation over its runs, the reserved pass
                           rate's 95 % interval, Welch t tests and bootstrap intervals of its difference
                           to uniform and to paper, an ANOVA and a permutation test (aaai.train.power)
  curves.csv, curves.png   training pass rate against training steps, mean and spread over seeds
  reserved_curves.csv/.png with --curve-seeds-per-cell: every checkpoint's pass rate on reserved seeds
                           (each run's curve.csv and curve/), against decisions and training wall time

The tables and plots are written after every run, from the runs scored so far; `aaai experiment
report FOLDER` writes them without running anything (while the experiment runs, say).

Re-running the same command continues: finished runs and whole scoreboards are skipped, an
unfinished run resumes from its newest checkpoint, a half-written scoreboard is completed (a run
trained to the budget and fully scored is finished without its model, which the committed runs do
not keep). A folder run with another base config or K is not continued: the refusal names what
differs (the sampler and seed each run sets for itself are not compared). The command's settings
are pinned in configs/curricula.yaml, so that a change of configs/default.yaml leaves the committed
experiment continuable.

The curve is the cell-averaged training pass rate: at each step, the mean over all active cells
of each cell's pass rate over its last ``window`` training episodes (a cell not yet played counts
0). Averaging over cells (not over episodes) keeps it comparable between samplers that play
different cells.
"""

from __future__ import annotations

import concurrent.futures
import csv
import math
import multiprocessing
import shutil
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import yaml

from aaai import safe_yaml
from aaai.config import Config, ConfigError, load_config
from aaai.files import atomic_path, write_atomic
from aaai.scoring.curves import (
    CURVE_COLUMNS,
    checkpoint_points,
    csv_text,
    pass_pct,
    read_board,
    read_curve,
    score_curve,
)
from aaai.scoring.runs import RunFolder
from aaai.train.curriculum import SAMPLERS, episode_passed

CURVE_POINTS = 20
DEFAULT_FOLDER = Path("experiments/curricula")


@dataclass
class Experiment:
    folder: Path
    samplers: list[str]
    seeds: list[int]
    config: Config  # the resolved base config: cells, budget, action mode; sampler and seed set per run
    seeds_per_cell: int
    # reserved seeds per cell each checkpoint (train.checkpoint_every apart) is scored on: 0, none
    curve_seeds_per_cell: int = 0

    def run_config(self, sampler: str, seed: int) -> Config:
        return load_config(self.config, mode="curriculum", sampler=sampler, seed=seed)

    def run_dir(self, sampler: str, seed: int) -> Path:
        return self.folder / f"{sampler}-seed{seed}"

    def record(self) -> dict:
        record: dict = {"samplers": self.samplers, "seeds": self.seeds, "seeds_per_cell": self.seeds_per_cell}
        if self.curve_seeds_per_cell:  # an experiment without checkpoint curves keeps its record as it was
            record["curve_seeds_per_cell"] = self.curve_seeds_per_cell
        return {**record, "config": self.config.to_dict()}


def recorded(folder: str | Path) -> Experiment:
    """The experiment ``folder`` records (its experiment.yaml), as it was planned: to write its tables
    without running anything."""
    path = Path(folder) / "experiment.yaml"
    if not path.is_file():
        raise ConfigError(
            f"FOLDER: {str(folder)!r} has no experiment.yaml; allowed: a folder of `aaai experiment curricula`"
        )
    record = safe_yaml.load_mapping(path, "experiment record")
    try:
        return Experiment(
            Path(folder),
            [str(s) for s in record["samplers"]],
            [int(s) for s in record["seeds"]],
            load_config(record["config"]),
            int(record["seeds_per_cell"]),
            int(record.get("curve_seeds_per_cell") or 0),
        )
    except (KeyError, TypeError, ValueError) as error:
        raise ConfigError(f"FOLDER: {str(path)!r} is not an experiment record ({error!r})") from None


def plan(
    folder: str | Path,
    samplers: list[str],
    seeds: list[int],
    config: Config,
    seeds_per_cell: int,
    curve_seeds_per_cell: int = 0,
) -> Experiment:
    """The experiment in ``folder``; refused if the folder holds another experiment."""
    bad = [s for s in samplers if s not in SAMPLERS]
    if bad or not samplers:
        unknown = f" ({bad[0]!r} is not a sampler)" if bad else ""
        raise ConfigError(f"--samplers: got {','.join(samplers)!r}{unknown}; allowed: a list of {', '.join(SAMPLERS)}")
    if not seeds:
        raise ConfigError("--seeds: got none; allowed: 1 or more training seeds")
    if curve_seeds_per_cell > seeds_per_cell:
        raise ConfigError(
            f"--curve-seeds-per-cell: got {curve_seeds_per_cell}; allowed: 0 to K (-k, {seeds_per_cell}): the "
            "final point of a curve is the run's reserved scoreboard"
        )
    experiment = Experiment(Path(folder), list(samplers), list(seeds), config, seeds_per_cell, curve_seeds_per_cell)
    path = experiment.folder / "experiment.yaml"
    if path.exists():
        earlier = safe_yaml.load_mapping(path, "experiment record")  # plain data within limits
        # resolved again: keys added to the config since then take their defaults, as in `config`
        differences = config_differences(load_config(earlier.get("config") or {}), load_config(config))
        if earlier.get("seeds_per_cell") != seeds_per_cell:
            differences.insert(0, ("K (-k, seeds per cell)", earlier.get("seeds_per_cell"), seeds_per_cell))
        if (earlier.get("curve_seeds_per_cell") or 0) != curve_seeds_per_cell:
            differences.insert(
                0, ("--curve-seeds-per-cell", earlier.get("curve_seeds_per_cell") or 0, curve_seeds_per_cell)
            )
        if differences:
            raise ConfigError(refusal(experiment.folder, differences))
        # more samplers or seeds than before: the runs already done are kept
        experiment.samplers = list(dict.fromkeys(earlier["samplers"] + experiment.samplers))
        experiment.seeds = sorted(set(earlier["seeds"]) | set(experiment.seeds))
    write_atomic(path, yaml.safe_dump(experiment.record(), sort_keys=False))
    return experiment


# the keys each run sets for itself (Experiment.run_config): the base config's values do not matter
PER_RUN_KEYS = ("curriculum.sampler", "train.seed")
LISTED_DIFFERENCES = 5


def config_differences(earlier: Config, now: Config) -> list[tuple[str, object, object]]:
    """(key, value in the folder, value now) for each key of two resolved configs that differs,
    leaving out the keys each run sets (PER_RUN_KEYS)."""
    before, after = earlier.flat(), now.flat()
    keys = [key for key in dict.fromkeys([*before, *after]) if key not in PER_RUN_KEYS]
    return [(key, before.get(key), after.get(key)) for key in keys if before.get(key) != after.get(key)]


def refusal(folder: Path, differences: list[tuple[str, object, object]]) -> str:
    """The message refusing to continue the experiment in ``folder``: what differs, and what to do."""
    listed = "; ".join(
        f"{key}: {was!r} in the folder, {now!r} now" for key, was, now in differences[:LISTED_DIFFERENCES]
    )
    more = len(differences) - LISTED_DIFFERENCES
    if more > 0:
        listed += f"; and {more} more"
    return (
        f"--out: {str(folder)!r} holds an experiment with another config or K ({listed}). To continue it, re-run "
        f"it with the options and --config file it was run with (by default configs/curricula.yaml; the folder's "
        f"whole config is in {str(folder / 'experiment.yaml')!r}), or choose another --out"
    )


# --- running ------------------------------------------------------------------------------
def finished(run: RunFolder, total_steps: int) -> bool:
    """Has the run saved its final point at or past ``total_steps`` (with its model, for PPO)?"""
    try:
        needs_model = load_config(run.read_config()).train.agent == "ppo"
        done = RunFolder.unreadable(run.final, needs_model) is None
        return done and int(RunFolder.read_state(run.final)["step"]) >= total_steps
    except (OSError, ValueError, KeyError, ConfigError):
        return False


def train_run(experiment: Experiment, sampler: str, seed: int, echo: Callable[[str], None], report=None) -> RunFolder:
    """Trains one run to the budget: skipped when finished, resumed when started, else started.
    ``report`` (an aaai.train.training.Progress) is told of its steps and episodes."""
    from aaai.train.training import train

    config = experiment.run_config(sampler, seed)
    run = RunFolder(experiment.run_dir(sampler, seed))
    total = config.train.total_steps
    if finished(run, total):
        echo(f"{run.path}: trained ({total} steps), skipped")
        return run
    if kept_results(experiment, run, total):
        echo(f"{run.path}: trained ({total} steps) and scored, without its model (not kept), skipped")
        return run
    hooks = {"progress": report.update, "on_episodes": report.on_episodes} if report is not None else {}
    if run.config_path.is_file() and run.saved():
        echo(f"{run.path}: resuming")
        train(run.path, resume=True, say=echo, **hooks)
        return run
    if run.path.exists():  # started but nothing saved yet: start again
        shutil.rmtree(run.path)
    echo(f"{run.path}: training {sampler}, seed {seed}, {total} steps")
    train(run.path, config, say=echo, **hooks)
    return run


def trained_seeds(run: RunFolder, cells: list[tuple[int, int]], count: int) -> dict[tuple[int, int], list[int]]:
    """Per cell, the last ``count`` distinct seeds the run trained on (fewer if it played fewer)."""
    played: dict[tuple[int, int], list[int]] = {cell: [] for cell in cells}
    for row in read_episodes(run.path):
        cell = (int(row["level"]), int(row["difficulty"]))
        if cell in played:
            played[cell].append(int(row["seed"]))
    return {cell: list(dict.fromkeys(reversed(seeds)))[:count] for cell, seeds in played.items()}


def scoreboards(experiment: Experiment, run: RunFolder) -> dict[str, tuple[list, Path, str]]:
    """The run's two scoreboards: name -> (cells and seeds, file, seeds mode of its record)."""
    from aaai.scoring.evaluation import Cell, cells_for

    cur = load_config(run.read_config()).curriculum
    k = experiment.seeds_per_cell
    reserved = cells_for(list(cur.levels), list(cur.difficulties), "reserved", k)
    own = trained_seeds(run, [(c.level, c.difficulty) for c in reserved], k)
    trained = [Cell(level, d, seeds) for (level, d), seeds in own.items() if seeds]
    return {
        "reserved": (reserved, run.path / "scoreboard_reserved.csv", "reserved"),
        "trained": (trained, run.path / "scoreboard_trained.csv", "list"),
    }


def scored(cells: list, output: Path) -> bool:
    from aaai.scoring.evaluation import scored_episodes

    return output.exists() and len(scored_episodes(output)) >= sum(len(c.seeds) for c in cells)


def kept_results(experiment: Experiment, run: RunFolder, total_steps: int) -> bool:
    """Did the run train to ``total_steps`` and fill both scoreboards, though its model is gone?
    The committed runs keep no model (experiments/curricula/.gitignore): they are done, not resumed."""
    try:
        trained = RunFolder.unreadable(run.final, needs_model=False) is None
        trained = trained and int(RunFolder.read_state(run.final)["step"]) >= total_steps
        return trained and all(scored(cells, output) for cells, output, _ in scoreboards(experiment, run).values())
    except (OSError, ValueError, KeyError, ConfigError):
        return False


def score_run(experiment: Experiment, run: RunFolder, echo: Callable[[str], None]) -> dict[str, Path]:
    """The run's two scoreboards (reserved seeds, seeds it trained on), each played only as far as missing."""
    from aaai.scoring.evaluation import evaluate, policy_record
    from aaai.scoring.policies import resolve

    one_torch_thread()
    config = load_config(run.read_config())
    boards = scoreboards(experiment, run)
    for cells, output, seeds_mode in boards.values():
        wanted = sum(len(c.seeds) for c in cells)
        if scored(cells, output):
            echo(f"{output}: scored ({wanted} episodes), skipped")
            continue
        echo(f"{output}: scoring {wanted} episodes")
        policy = resolve(str(run.path))
        evaluate(policy, cells, output, config, record=policy_record(policy, seeds_mode))
    return {name: output for name, (_, output, _) in boards.items()}


def run_one(
    experiment: Experiment,
    sampler: str,
    seed: int,
    echo: Callable[[str], None] = print,
    progress_every: float | None = None,
    prune: bool = False,
) -> None:
    """Trains and scores one (sampler, seed), as far as not done: its two scoreboards, then (with
    curve seeds) every checkpoint on the reserved seeds; ``prune`` then deletes its scored checkpoints."""
    from aaai.jobs import print_lines
    from aaai.train.training import Progress

    name = f"{sampler}-seed{seed}"
    report = None
    if progress_every is not None:
        report = Progress(
            experiment.config.train.total_steps,
            label=f"training {name}",
            every=progress_every,
            write=print_lines(sys.stdout),
        )
    run = train_run(experiment, sampler, seed, echo, report)
    score_run(experiment, run, echo)
    if experiment.curve_seeds_per_cell:
        score_checkpoints(experiment, run, echo)
        if prune:
            prune_checkpoints(experiment, run, echo)


def _job(experiment: Experiment, sampler: str, seed: int, progress_every: float | None, prune: bool) -> None:
    run_one(experiment, sampler, seed, print_flushed, progress_every, prune)


def print_flushed(text: str) -> None:
    print(text, flush=True)


def one_torch_thread() -> None:
    """One torch thread per run: runs share the cores, and torch's idle threads spinning beside
    another run made scoring several times slower (as the learner, aaai.train.learner, does in training)."""
    try:
        import torch
    except ImportError:
        return
    torch.set_num_threads(1)


def run_experiment(
    experiment: Experiment,
    echo: Callable[[str], None] = print,
    progress_every: float | None = None,
    jobs: int = 1,
    prune: bool = False,
) -> list[dict]:
    """Trains and scores every (sampler, seed) not yet done, ``jobs`` runs at a time (each in its
    own process), then writes the table and the plot. Runs go seed by seed: an experiment stopped
    early has every sampler on its first seeds."""
    pairs = run_order(experiment)
    if jobs <= 1:
        done = set(scored_pairs(experiment))
        for sampler, seed in pairs:
            run_one(experiment, sampler, seed, echo, progress_every, prune)
            if (sampler, seed) not in done and (sampler, seed) != pairs[-1]:  # the last is written below
                write_results(experiment, finished_rows(experiment))  # the tables so far, after every run
    else:
        context = multiprocessing.get_context("forkserver")
        with concurrent.futures.ProcessPoolExecutor(max_workers=jobs, mp_context=context) as pool:
            futures = [pool.submit(_job, experiment, sampler, seed, progress_every, prune) for sampler, seed in pairs]
            for future in futures:
                future.result()  # the first failure is raised here, after the runs under way end
    rows = finished_rows(experiment)
    write_results(experiment, rows)
    return rows


def scored_pairs(experiment: Experiment) -> list[tuple[str, int]]:
    """(sampler, seed) of the runs whose reserved scoreboard is whole, sampler by sampler."""
    cur = experiment.config.curriculum
    wanted = len(cur.levels) * len(cur.difficulties) * experiment.seeds_per_cell
    return [
        (sampler, seed)
        for sampler in experiment.samplers
        for seed in experiment.seeds
        if len(read_board(experiment.run_dir(sampler, seed) / "scoreboard_reserved.csv")) >= wanted
    ]


def finished_rows(experiment: Experiment) -> list[dict]:
    """runs.csv's rows: one per run scored on its reserved seeds (an experiment under way has fewer)."""
    return [run_row(experiment, sampler, seed) for sampler, seed in scored_pairs(experiment)]


def run_order(experiment: Experiment) -> list[tuple[str, int]]:
    """(sampler, seed) in the order they run: seed-major (every sampler's first seed, then every
    sampler's second...), so that an experiment stopped early has as many runs of each sampler, give or take one."""
    return [(sampler, seed) for seed in experiment.seeds for sampler in experiment.samplers]


# --- learning curves on reserved seeds ----------------------------------------------------------
RESERVED_CURVE_COLUMNS = ["sampler", "seed", *CURVE_COLUMNS]


def score_checkpoints(experiment: Experiment, run: RunFolder, echo: Callable[[str], None]) -> Path:
    """Scores each checkpoint of a trained run on the first ``curve_seeds_per_cell`` reserved seeds of
    its cells (:func:`aaai.scoring.curves.score_curve`) and writes its curve.csv. The final point is
    the run's reserved scoreboard on those seeds (no episode played again)."""
    from aaai.scoring.evaluation import cells_for

    config = load_config(run.read_config())
    cur = config.curriculum
    cells = cells_for(list(cur.levels), list(cur.difficulties), "reserved", experiment.curve_seeds_per_cell)
    random_agent = config.train.agent == "random"  # its checkpoints hold no model: scored with random actions
    one_torch_thread()
    return score_curve(
        run,
        cells,
        config,
        echo,
        final_rows=read_board(run.path / "scoreboard_reserved.csv"),
        policy_of=(lambda point: str(run.path)) if random_agent else None,
        needs_model=not random_agent,
    )


def prune_checkpoints(experiment: Experiment, run: RunFolder, echo: Callable[[str], None]) -> None:
    """Deletes a finished run's checkpoints/step_* once curve.csv holds each of them (final/ stays)."""
    if not finished(run, experiment.config.train.total_steps):
        return
    curve = read_curve(run.path / "curve.csv")
    points = checkpoint_points(run, needs_model=False)
    if points and all(step in curve for step, _ in points):
        shutil.rmtree(run.checkpoints)
        echo(f"{run.checkpoints}: {len(points)} checkpoint(s) scored, deleted")


def reserved_curves(experiment: Experiment) -> list[dict]:
    """Every run's curve.csv rows, with its sampler and seed."""
    rows = []
    for sampler, seed in run_order(experiment):
        for row in read_curve(experiment.run_dir(sampler, seed) / "curve.csv").values():
            rows.append({"sampler": sampler, "seed": seed, **row})
    return rows


# --- results ------------------------------------------------------------------------------
def read_episodes(folder: Path) -> list[dict]:
    path = Path(folder) / "episodes.csv"
    if not path.is_file():
        return []
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


RUN_COLUMNS = [
    "sampler",
    "seed",
    "steps",
    "episodes",
    "cells_played",
    "fewest_episodes_per_cell",
    "reserved_episodes",
    "reserved_pass_pct",
    "reserved_mean_return",
    "trained_episodes",
    "trained_pass_pct",
    "gap_pct",
]


def run_row(experiment: Experiment, sampler: str, seed: int) -> dict:
    run = RunFolder(experiment.run_dir(sampler, seed))
    cur = experiment.config.curriculum
    cells = [(level, d) for level in cur.levels for d in cur.difficulties]
    episodes = read_episodes(run.path)
    counts = [sum(1 for e in episodes if (int(e["level"]), int(e["difficulty"])) == cell) for cell in cells]
    reserved = read_board(run.path / "scoreboard_reserved.csv")
    trained = read_board(run.path / "scoreboard_trained.csv")
    state = RunFolder.read_state(run.final) if (run.final / "state.json").is_file() else {"step": 0}
    reserved_pass, trained_pass = pass_pct(reserved), pass_pct(trained)
    row: dict[str, object] = {
        "sampler": sampler,
        "seed": seed,
        "steps": state["step"],
        "episodes": len(episodes),
        "cells_played": sum(c > 0 for c in counts),
        "fewest_episodes_per_cell": min(counts),
        "reserved_episodes": len(reserved),
        "reserved_pass_pct": reserved_pass,
        "reserved_mean_return": float(np.mean([float(r["return"]) for r in reserved])) if reserved else math.nan,
        "trained_episodes": len(trained),
        "trained_pass_pct": trained_pass,
        "gap_pct": trained_pass - reserved_pass,
    }
    return row


REFERENCES = ("uniform", "paper")  # each sampler's reserved pass rate is compared with these
TABLE_COLUMNS = [
    "sampler",
    "runs",
    "reserved_pass_pct_mean",
    "reserved_pass_pct_std",
    "reserved_pass_pct_ci95_low",
    "reserved_pass_pct_ci95_high",
    *[
        f"{part}_vs_{reference}"
        for reference in REFERENCES
        for part in ("difference", "welch_t", "welch_df", "welch_p", "bootstrap95_low", "bootstrap95_high")
    ],
    "reserved_mean_return",
    "trained_pass_pct_mean",
    "trained_pass_pct_std",
    "gap_pct_mean",
    "cells_played_mean",
    "fewest_episodes_per_cell_mean",
]


def reserved_rates(rows: list[dict]) -> dict[str, list[float]]:
    """Per sampler, the reserved pass rates (%) of its scored runs."""
    rates: dict[str, list[float]] = {}
    for row in rows:
        value = float(row["reserved_pass_pct"])
        rates.setdefault(row["sampler"], [])
        if not math.isnan(value):
            rates[row["sampler"]].append(value)
    return rates


def comparisons(rows: list[dict]) -> dict[str, dict]:
    """Per sampler: its reserved pass rate's 95 % t interval over seeds and, against each of
    REFERENCES present, the difference of means, Welch's t test and a bootstrap 95 % interval."""
    from aaai.train.power import bootstrap_difference, mean_interval, welch

    rates = reserved_rates(rows)
    out: dict[str, dict] = {}
    for sampler, values in rates.items():
        _, low, high = mean_interval(values)
        tests: dict[str, float] = {"reserved_pass_pct_ci95_low": low, "reserved_pass_pct_ci95_high": high}
        for reference in REFERENCES:
            other = rates.get(reference, [])
            same = reference == sampler or not other or not values
            t, df, p = (math.nan,) * 3 if same else welch(values, other)
            boot = (math.nan, math.nan) if same else bootstrap_difference(values, other)
            tests |= {
                f"difference_vs_{reference}": math.nan if same else float(np.mean(values) - np.mean(other)),
                f"welch_t_vs_{reference}": t,
                f"welch_df_vs_{reference}": df,
                f"welch_p_vs_{reference}": p,
                f"bootstrap95_low_vs_{reference}": boot[0],
                f"bootstrap95_high_vs_{reference}": boot[1],
            }
        out[sampler] = tests
    return out


def table(rows: list[dict]) -> list[dict]:
    """Per sampler: mean and (sample) standard deviation over its runs, the interval of its
    reserved pass rate and its tests against REFERENCES (:func:`comparisons`)."""
    tests = comparisons(rows)
    out = []
    for sampler in dict.fromkeys(r["sampler"] for r in rows):
        group = [r for r in rows if r["sampler"] == sampler]

        def mean(key):
            values = [r[key] for r in group if not math.isnan(r[key])]
            return float(np.mean(values)) if values else math.nan

        def std(key):
            values = [r[key] for r in group if not math.isnan(r[key])]
            return float(np.std(values, ddof=1)) if len(values) > 1 else math.nan

        out.append(
            {
                "sampler": sampler,
                "runs": len(group),
                "reserved_pass_pct_mean": mean("reserved_pass_pct"),
                "reserved_pass_pct_std": std("reserved_pass_pct"),
                **tests[sampler],
                "reserved_mean_return": mean("reserved_mean_return"),
                "trained_pass_pct_mean": mean("trained_pass_pct"),
                "trained_pass_pct_std": std("trained_pass_pct"),
                "gap_pct_mean": mean("gap_pct"),
                "cells_played_mean": mean("cells_played"),
                "fewest_episodes_per_cell_mean": mean("fewest_episodes_per_cell"),
            }
        )
    return out


def table_markdown(summary: list[dict], experiment: Experiment, rows: list[dict] | None = None) -> str:
    cur, train = experiment.config.curriculum, experiment.config.train

    def pm(mean, std):
        return "-" if math.isnan(mean) else f"{mean:.1f}" + ("" if math.isnan(std) else f" ± {std:.1f}")

    runs = sum(s["runs"] for s in summary)
    planned = len(experiment.samplers) * len(experiment.seeds)
    lines = [
        f"Levels {list(cur.levels)} x difficulties {list(cur.difficulties)}, "
        f"{train.total_steps} steps per run, action mode {experiment.config.agent.action_mode}, "
        f"warm-up {cur.warmup}, seeds {experiment.seeds}, K = {experiment.seeds_per_cell} seeds per cell. "
        "Pass rates in %, mean ± standard deviation over the training seeds.",
        "",
        *([] if runs == planned else [f"**Under way: {runs} of {planned} runs scored.**", ""]),
        "| sampler | runs | reserved seeds: pass % | mean return | trained seeds: pass % | gap (trained - reserved) "
        "| cells played | fewest episodes in a cell |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for s in summary:
        lines.append(
            f"| {s['sampler']} | {s['runs']} | {pm(s['reserved_pass_pct_mean'], s['reserved_pass_pct_std'])} "
            f"| {s['reserved_mean_return']:.3f} | {pm(s['trained_pass_pct_mean'], s['trained_pass_pct_std'])} "
            f"| {s['gap_pct_mean']:+.1f} | {s['cells_played_mean']:.1f} | {s['fewest_episodes_per_cell_mean']:.1f} |"
        )
    return "\n".join(lines) + "\n" + tests_markdown(summary, rows or [])


def number(value: float, digits: int = 1) -> str:
    return "-" if math.isnan(value) else f"{value:.{digits}f}"


def tests_markdown(summary: list[dict], rows: list[dict]) -> str:
    """The reserved pass rate's intervals and the tests of its differences, as markdown."""
    from aaai.train.power import RESAMPLES, anova, permutation_anova

    lines = [
        "",
        "Reserved pass rate: mean over seeds with its 95 % t interval; against each reference, the difference of "
        f"means, Welch's t test (t, degrees of freedom, two-sided p) and a percentile bootstrap 95 % interval of the "
        f"difference ({RESAMPLES:,} resamples of the runs, seed 0). scipy.stats.",
        "",
        "| sampler | runs | reserved pass % [95 % interval] |"
        + "".join(f" against {r}: difference, Welch t (df), p | bootstrap 95 % |" for r in REFERENCES),
        "|---|---:|---:|" + "---:|---:|" * len(REFERENCES),
    ]
    for s in summary:
        cells = [
            f"| {s['sampler']} | {s['runs']} | {number(s['reserved_pass_pct_mean'])} "
            f"[{number(s['reserved_pass_pct_ci95_low'])}, {number(s['reserved_pass_pct_ci95_high'])}] |"
        ]
        for r in REFERENCES:
            if math.isnan(s[f"difference_vs_{r}"]):
                cells.append(" - | - |")
                continue
            cells.append(
                f" {s[f'difference_vs_{r}']:+.1f}, t = {number(s[f'welch_t_vs_{r}'], 2)} "
                f"({number(s[f'welch_df_vs_{r}'])}), p = {number(s[f'welch_p_vs_{r}'], 3)} "
                f"| [{number(s[f'bootstrap95_low_vs_{r}'])}, {number(s[f'bootstrap95_high_vs_{r}'])}] |"
            )
        lines.append("".join(cells))
    groups = list(reserved_rates(rows).values())
    f, p = anova(groups)
    permuted = permutation_anova(groups)
    lines += [
        "",
        f"All samplers at once: one-way ANOVA F = {number(f, 2)}, p = {number(p, 3)}; permutation test of F "
        f"({RESAMPLES:,} relabellings of the runs, seed 0): p = {number(permuted, 3)}.",
    ]
    return "\n".join(lines) + "\n"


def cell_pass_curve(episodes: list[dict], cells: list[tuple[int, int]], steps: np.ndarray, window: int) -> np.ndarray:
    """At each of ``steps``: the mean over ``cells`` of each cell's pass rate over its last
    ``window`` episodes logged at or before that step (0 for a cell not yet played)."""
    by_cell: dict[tuple[int, int], list[tuple[int, bool]]] = {cell: [] for cell in cells}
    for e in episodes:
        cell = (int(e["level"]), int(e["difficulty"]))
        if cell in by_cell:
            by_cell[cell].append((int(e["step"]), episode_passed(float(e["task_return"]), float(e["max_reward"]))))
    curve = np.zeros(len(steps))
    for played in by_cell.values():
        at = np.array([s for s, _ in played], dtype=np.int64)
        passed = np.array([p for _, p in played], dtype=np.float64)
        for i, step in enumerate(steps):
            n = int(np.searchsorted(at, step, side="right"))
            if n:
                curve[i] += passed[max(0, n - window) : n].mean()
    return curve / len(cells)


def curves(experiment: Experiment, pairs: list[tuple[str, int]]) -> tuple[np.ndarray, list[dict]]:
    """The training pass rate of the runs ``pairs`` (sampler, seed) at CURVE_POINTS steps."""
    cur = experiment.config.curriculum
    cells = [(level, d) for level in cur.levels for d in cur.difficulties]
    runs = {(sampler, seed): read_episodes(experiment.run_dir(sampler, seed)) for sampler, seed in pairs}
    last = max((int(e["step"]) for episodes in runs.values() for e in episodes), default=0)
    total = max(experiment.config.train.total_steps, last)  # PPO ends on a whole rollout
    steps = np.linspace(0, total, CURVE_POINTS + 1)[1:].round().astype(np.int64)
    rows = []
    for sampler, seed in pairs:
        curve = cell_pass_curve(runs[(sampler, seed)], cells, steps, cur.window)
        rows += [
            {"sampler": sampler, "seed": seed, "step": int(s), "cell_pass_rate": float(v)} for s, v in zip(steps, curve)
        ]
    return steps, rows


def write_results(experiment: Experiment, rows: list[dict]) -> None:
    folder = experiment.folder
    write_atomic(folder / "runs.csv", csv_text(rows, RUN_COLUMNS))
    summary = table(rows)
    write_atomic(folder / "table.csv", csv_text(summary, TABLE_COLUMNS))
    write_atomic(folder / "table.md", table_markdown(summary, experiment, rows))
    if experiment.curve_seeds_per_cell:
        scored_curves = reserved_curves(experiment)
        write_atomic(folder / "reserved_curves.csv", csv_text(scored_curves, RESERVED_CURVE_COLUMNS))
        if scored_curves:
            plot_checkpoints([folder], folder / "reserved_curves.png")
    pairs = [(r["sampler"], r["seed"]) for r in rows]
    steps, curve_rows = curves(experiment, pairs)
    write_atomic(folder / "curves.csv", csv_text(curve_rows, ["sampler", "seed", "step", "cell_pass_rate"]))
    series = {}
    for sampler in experiment.samplers:
        values = np.array(
            [
                [r["cell_pass_rate"] for r in curve_rows if r["sampler"] == sampler and r["seed"] == seed]
                for seed in experiment.seeds
                if (sampler, seed) in pairs
            ]
        )
        series[sampler] = values
    whole = len(pairs) == len(experiment.samplers) * len(experiment.seeds)
    runs_text = f"{len(experiment.seeds)} seed(s) per sampler" if whole else f"{len(pairs)} run(s) scored so far"
    plot_spread(
        steps,
        series,
        folder / "curves.png",
        title=f"{runs_text}: mean, band = min to max over seeds",
        ylabel="training pass rate (mean over cells)",
    )


# --- pictures -----------------------------------------------------------------------------
def _pyplot():
    try:
        import matplotlib
    except ImportError:
        raise ImportError("plots need matplotlib (the train extra: pip install -e '.[train]')") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_spread(steps: np.ndarray, series: dict[str, np.ndarray], path: Path, title: str, ylabel: str) -> None:
    """One line per name (the mean of its rows) with a band from the lowest to the highest row."""
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(7, 4.2), dpi=110)
    for name, values in series.items():
        if values.size == 0:
            continue
        (line,) = axes.plot(steps, values.mean(axis=0), label=name)
        if len(values) > 1:
            axes.fill_between(steps, values.min(axis=0), values.max(axis=0), color=line.get_color(), alpha=0.2)
    axes.set_xlabel("training steps")
    axes.set_ylabel(ylabel)
    axes.set_ylim(-0.02, 1.02)
    axes.set_title(title, fontsize=9)
    axes.grid(alpha=0.3)
    axes.legend()
    save(figure, path)


def save(figure, path: Path) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format="png", bbox_inches="tight")
    figure.clear()
    _pyplot().close(figure)


def plot_runs(runs: list[str | Path], path: str | Path, smooth: int = 50) -> Path:
    """`aaai plot`: the learning curves of runs on one figure, from their episodes.csv: task
    return (without shaping) and pass rate, each a running mean over ``smooth`` episodes, against
    training steps."""
    plt = _pyplot()
    data = []
    for run in runs:
        folder = Path(run)
        RunFolder(folder).read_config()  # a clear error for a folder that is not a run
        episodes = read_episodes(folder)
        if not episodes:
            raise ConfigError(f"RUN: got {str(folder)!r}, which has no finished episode yet (episodes.csv)")
        data.append((folder, episodes))
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), dpi=110, sharex=True)
    for folder, episodes in data:
        steps = np.array([int(e["step"]) for e in episodes])
        returns = np.array([float(e["task_return"]) for e in episodes])
        passed = np.array([episode_passed(float(e["task_return"]), float(e["max_reward"])) for e in episodes], float)
        label = folder.name if len({f.name for f, _ in data}) == len(data) else str(folder)
        top.plot(steps, running_mean(returns, smooth), label=label)
        bottom.plot(steps, running_mean(passed, smooth), label=label)
    top.set_ylabel(f"task return (mean of last {smooth})")
    bottom.set_ylabel(f"pass rate (last {smooth})")
    bottom.set_ylim(-0.02, 1.02)
    bottom.set_xlabel("training steps")
    for axes in (top, bottom):
        axes.grid(alpha=0.3)
    top.legend(fontsize=8)
    save(figure, Path(path))
    return Path(path)


def running_mean(values: np.ndarray, width: int) -> np.ndarray:
    """Mean of each value and up to ``width - 1`` before it."""
    sums = np.cumsum(np.concatenate([[0.0], values]))
    ends = np.arange(1, len(values) + 1)
    starts = np.maximum(0, ends - width)
    return (sums[ends] - sums[starts]) / (ends - starts)


# --- learning curves on reserved seeds, from checkpoint scoreboards -----------------------------
GROUP_COLUMNS = ("sampler", "recipe", "mode", "label")  # the first a scoreboard has names its lines


def is_checkpoint_source(path: Path) -> bool:
    """A source `aaai plot` draws reserved-seed curves from: an experiment folder or a CSV file."""
    return path.is_file() or (path / "experiment.yaml").is_file()


def checkpoint_rows(source: Path) -> list[dict]:
    """(group, seed, step, seconds, pass_pct) rows of a checkpoint scoreboard: an experiment folder
    (its runs' curve.csv) or a CSV with a step (or decisions) column and pass_pct (or pass_rate, a
    fraction); optional seconds, seed and a group column (GROUP_COLUMNS; else the file's name)."""
    if source.is_dir():
        return [
            {"group": r["sampler"], "seed": str(r["seed"]), **{k: r[k] for k in ("step", "seconds", "pass_pct")}}
            for r in reserved_curves(recorded(source))
        ]
    if source.suffix != ".csv":
        raise ConfigError(f"SOURCE: got {str(source)!r}; allowed: a run or experiment folder, or a .csv scoreboard")
    try:
        rows = read_board(source)
    except (UnicodeDecodeError, csv.Error) as error:
        raise ConfigError(f"SOURCE: {str(source)!r} cannot be read as CSV ({error})") from None
    columns = set(rows[0]) if rows else set()
    step = next((c for c in ("step", "decisions") if c in columns), None)
    rate = next((c for c in ("pass_pct", "pass_rate") if c in columns), None)
    if step is None or rate is None:
        raise ConfigError(
            f"SOURCE: {str(source)!r} has no {'step (or decisions)' if step is None else 'pass_pct (or pass_rate)'} "
            "column; allowed: a checkpoint scoreboard (step, pass_pct[, seconds, seed, sampler]) or a folder"
        )
    group = next((c for c in GROUP_COLUMNS if c in columns), None)
    name = source.parent.name if source.name == "curve.csv" else source.stem  # a run's curve.csv: the run's name
    scale = 100.0 if rate == "pass_rate" else 1.0
    try:
        return [
            {
                "group": r[group] if group else name,
                "seed": f"{source}:{r.get('seed', '0')}",  # a seed of one file, never merged with another's
                "step": float(r[step]),
                "seconds": float(r.get("seconds") or "nan"),
                "pass_pct": float(r[rate]) * scale,
            }
            for r in rows
        ]
    except (TypeError, ValueError) as error:
        raise ConfigError(f"SOURCE: {str(source)!r} has a value that is not a number ({error})") from None


FINAL_TOLERANCE = 0.99  # a seed whose last point is this close to the group's last step counts to the end


def band_over_seeds(by_seed: dict[str, list[dict]]) -> dict[str, np.ndarray]:
    """One group's seeds on the union of their steps (each seed interpolated within its own range,
    and held at its last value to the group's last step when it ends within 1 % of it, as runs of one
    budget end a rollout apart): steps, median seconds (one run timed on a loaded machine moves a
    mean), mean pass rate and its 95 % t interval over the seeds present at each step."""
    from scipy import stats

    steps = np.array(sorted({float(r["step"]) for rows in by_seed.values() for r in rows}))
    passes: list[np.ndarray] = []
    seconds: list[np.ndarray] = []
    for rows in by_seed.values():
        rows = sorted(rows, key=lambda r: float(r["step"]))
        at = np.array([float(r["step"]) for r in rows])
        end = steps[-1] if at[-1] >= FINAL_TOLERANCE * steps[-1] else at[-1]  # runs end a rollout apart
        inside = (steps >= at[0]) & (steps <= end)
        for values, column in ((passes, "pass_pct"), (seconds, "seconds")):
            y = np.interp(steps, at, np.array([float(r[column]) for r in rows]))
            values.append(np.where(inside, y, np.nan))
    pass_array, second_array = np.array(passes), np.array(seconds)
    count = np.sum(~np.isnan(pass_array), axis=0)
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a step with one seed has no spread: NaN, no band
        mean = np.nanmean(pass_array, axis=0)
        spread = np.nanstd(pass_array, axis=0, ddof=1) if len(pass_array) > 1 else np.full(len(steps), np.nan)
        half = np.where(count > 1, stats.t.ppf(0.975, np.maximum(count - 1, 1)) * spread / np.sqrt(count), np.nan)
        time = np.nanmedian(second_array, axis=0) if not np.isnan(second_array).all() else np.full(len(steps), np.nan)
    return {"steps": steps, "seconds": time, "mean": mean, "low": mean - half, "high": mean + half, "seeds": count}


def plot_checkpoints(sources: list[str | Path], path: str | Path) -> Path:
    """`aaai plot` of checkpoint scoreboards: the reserved pass rate against decisions and against
    training wall time, one line per group (sampler, recipe) with its 95 % interval over seeds."""
    rows = []
    for source in sources:
        rows += checkpoint_rows(Path(source))
    if not rows:
        raise ConfigError(f"SOURCE: {', '.join(map(str, sources))} holds no scored checkpoint yet")
    groups: dict[str, dict[str, list[dict]]] = {}
    for row in rows:
        groups.setdefault(row["group"], {}).setdefault(row["seed"], []).append(row)
    bands = {name: band_over_seeds(by_seed) for name, by_seed in groups.items()}
    timed = any(not np.isnan(b["seconds"]).all() for b in bands.values())
    plt = _pyplot()
    figure, axes = plt.subplots(1, 2 if timed else 1, figsize=(11 if timed else 6.5, 4.2), dpi=110, squeeze=False)
    for name, band in bands.items():
        seeds = len(groups[name])
        label = f"{name} ({seeds} seed{'s' if seeds > 1 else ''})"
        panels = [(axes[0][0], band["steps"])] + ([(axes[0][1], band["seconds"] / 60.0)] if timed else [])
        for panel, x in panels:
            keep = ~np.isnan(x)
            (line,) = panel.plot(x[keep], band["mean"][keep], marker="o", markersize=3, label=label)
            if (band["seeds"] > 1).any():
                panel.fill_between(x[keep], band["low"][keep], band["high"][keep], color=line.get_color(), alpha=0.2)
    axes[0][0].xaxis.set_major_formatter(lambda x, _: f"{x / 1000:g}k" if x else "0")
    axes[0][0].set_xlabel("training decisions (agent steps)")
    if timed:
        axes[0][1].set_xlabel("training wall time (minutes, median over seeds)")
    for panel in axes[0]:
        panel.set_ylabel("pass rate on reserved seeds (%)")
        panel.set_ylim(-2, 102)
        panel.grid(alpha=0.3)
    axes[0][0].legend(fontsize=8)
    figure.suptitle("Pass rate on reserved seeds at each checkpoint: mean, band = 95 % interval over seeds", fontsize=9)
    save(figure, Path(path))
    return Path(path)
