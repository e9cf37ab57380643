"""`aaai experiment competence` (``make competence``): how long PPO needs to pass 90 % of reserved
L0 d0-2, in gait mode and in a joint mode, on this machine.

For each action mode, one PPO run on the shipped default config (the ``make demo`` run: L0
d0-2, its workers and rollouts) with that mode and a budget of its own, saving a
checkpoint every ``checkpoint_every`` agent decisions. Every checkpoint is then scored on the
reserved seeds of L0 d0-2 (10 per cell, 30 episodes). The time of a checkpoint is the wall-clock
time from the run's start (its config.yaml) to the checkpoint's state.json: training alone,
without the scoring. The folder (default experiments/competence/) gets:

  runs/<mode>/             each run folder, with scoreboard_<step>.csv per checkpoint
  competence.csv           per mode and checkpoint: decisions, control steps, seconds, pass rate
  table.md                 per mode: the first checkpoint at or above the target, or none

Re-running continues: a finished run is kept, an unfinished one resumes, scored checkpoints are
skipped. Wall-clock figures depend on the machine and its load; the file says which.
"""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from aaai.config import Config, load_config
from aaai.files import write_atomic
from aaai.scoring.evaluation import cells_for, evaluate
from aaai.scoring.runs import RunFolder

TARGET = 0.9


@dataclass(frozen=True)
class CompetenceSettings:
    """The experiment: action modes with their budgets (agent decisions) and checkpoint spacing."""

    budgets: dict[str, int] = field(default_factory=lambda: {"gait": 60_000, "rotation": 200_000})
    checkpoint_every: dict[str, int] = field(default_factory=lambda: {"gait": 5_000, "rotation": 20_000})
    levels: str = "0"
    difficulties: str = "0-2"
    seeds_per_cell: int = 10
    seed: int = 0
    target: float = TARGET


def run_config(settings: CompetenceSettings, mode: str) -> Config:
    return load_config(
        None,
        action_mode=mode,
        levels=settings.levels,
        difficulties=settings.difficulties,
        total_steps=settings.budgets[mode],
        checkpoint_every=settings.checkpoint_every[mode],
        seed=settings.seed,
    )


def train_mode(folder: Path, settings: CompetenceSettings, mode: str, echo: Callable[[str], None]) -> RunFolder:
    from aaai.train.training import train

    run = RunFolder(folder / "runs" / mode)
    final = run.final / "state.json"
    if final.is_file():
        return run
    resume = run.config_path.is_file()
    echo(f"{'resuming' if resume else 'training'} {mode}: {settings.budgets[mode]} agent decisions")
    train(run.path, None if resume else run_config(settings, mode), resume=resume, say=echo)
    return run


def checkpoints(run: RunFolder) -> list[tuple[int, Path]]:
    """(step, folder) of every saved point with a model, oldest first; final/ only if it is newer."""
    points: dict[int, Path] = {}
    for folder in run.saved():
        if (folder / "model.zip").is_file():
            step = run._step_of(folder)
            points.setdefault(int(step), folder)
    return sorted(points.items())


def score_mode(run: RunFolder, settings: CompetenceSettings, mode: str, echo: Callable[[str], None]) -> list[dict]:
    config = load_config(run.read_config())
    cur = config.curriculum
    cells = cells_for(list(cur.levels), list(cur.difficulties), "reserved", settings.seeds_per_cell)
    started = os.stat(run.config_path).st_mtime
    hold = (
        round(config.agent.decision_interval / (config.physics.timestep * config.physics.action_repeat))
        if mode == "gait"
        else 1
    )
    rows = []
    for step, point in checkpoints(run):
        board = run.path / f"scoreboard_{step:09d}.csv"
        scored = evaluate(str(point / "model.zip"), cells, board, config)
        passed = sum(row["outcome"] != "failed" for row in scored)
        rows.append(
            {
                "mode": mode,
                "decisions": step,
                "control_steps": step * hold,
                "seconds": round(os.stat(point / "state.json").st_mtime - started, 1),
                "passed": passed,
                "episodes": len(scored),
                "pass_rate": round(passed / len(scored), 4),
            }
        )
        echo(f"  {mode} at {step} decisions: {passed}/{len(scored)} passed")
    return rows


def run_experiment(
    folder: str | Path, settings: CompetenceSettings | None = None, echo: Callable[[str], None] = print
) -> Path:
    settings = settings or CompetenceSettings()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rows = []
    for mode in settings.budgets:
        run = train_mode(folder, settings, mode, echo)
        rows.extend(score_mode(run, settings, mode, echo))
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=list(rows[0]))
    writer.writeheader()
    writer.writerows(rows)
    write_atomic(folder / "competence.csv", text.getvalue())
    write_atomic(folder / "table.md", table_markdown(rows, settings))
    return folder / "table.md"


def table_markdown(rows: list[dict], settings: CompetenceSettings) -> str:
    lines = [
        f"| action mode | budget (agent decisions) | first checkpoint passing {100 * settings.target:.0f} % "
        "| control steps | training wall time | best pass rate |",
        "|---|---:|---|---:|---:|---:|",
    ]
    for mode in settings.budgets:
        mine = [r for r in rows if r["mode"] == mode]
        first = next((r for r in mine if r["pass_rate"] >= settings.target), None)
        best = max(mine, key=lambda r: r["pass_rate"]) if mine else None
        reached = (
            (
                f"{first['decisions']:,} decisions ({first['passed']}/{first['episodes']})",
                f"{first['control_steps']:,}",
                f"{first['seconds']:.0f} s",
            )
            if first
            else ("not reached", "-", "-")
        )
        best_text = f"{100 * best['pass_rate']:.0f} % at {best['decisions']:,}" if best else "-"
        lines.append(
            f"| {mode} | {settings.budgets[mode]:,} | {reached[0]} | {reached[1]} | {reached[2]} | {best_text} |"
        )
    return "\n".join(lines) + "\n"
