"""A run's learning curve on reserved seeds: each of its checkpoints scored on the same episodes.

``aaai eval --policy RUN --checkpoints`` and ``aaai experiment curricula --curve-seeds-per-cell``
both write it: ``curve/reserved_<step>.csv`` in the run (a scoreboard per checkpoint, resumed episode
by episode) and ``curve.csv`` (per checkpoint: its step, the training wall time to it, and its pass
rate on those episodes), which ``aaai plot RUN/curve.csv`` draws.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import Callable

from aaai.config import Config, ConfigError
from aaai.files import hold, write_atomic
from aaai.scoring.evaluation import evaluate, policy_record
from aaai.scoring.plan import Cell
from aaai.scoring.policies import resolve
from aaai.scoring.runs import RunFolder

CURVE_FOLDER = "curve"  # in each run: reserved_<step>.csv per checkpoint scored
CURVE_COLUMNS = ["step", "seconds", "episodes", "passed", "pass_pct"]


def checkpoint_points(run: RunFolder, needs_model: bool = True) -> list[tuple[int, Path]]:
    """(step, folder) of the run's checkpoints/step_* (with a model if ``needs_model``), oldest first
    (final/ not included)."""
    points = []
    for folder in sorted(run.checkpoints.glob("step_*")) if run.checkpoints.is_dir() else []:
        if (folder / "model.zip").is_file() or not needs_model and (folder / "state.json").is_file():
            points.append((int(RunFolder.read_state(folder)["step"]), folder))
    return sorted(points)


def every_nth(points: list[tuple[int, Path]], every: int) -> list[tuple[int, Path]]:
    """The first checkpoint at or past each multiple of ``every`` steps (all of them for 0)."""
    if every <= 0:
        return points
    kept, mark = [], 0
    for step, point in points:
        if step >= mark:
            kept.append((step, point))
            mark = (step // every + 1) * every
    return kept


def curve_points(run: RunFolder, every: int = 0, needs_model: bool = True) -> list[tuple[int, Path]]:
    """(step, folder) of the points of a run's curve: its checkpoints (each, or the first at each
    multiple of ``every`` steps) before its final model, then final/ if the run finished. ConfigError
    if there is none."""
    finished = (run.final / "state.json").is_file()
    final_step = int(RunFolder.read_state(run.final)["step"]) if finished else math.inf
    points = [(s, p) for s, p in every_nth(checkpoint_points(run, needs_model), every) if s < final_step]
    if finished:
        points.append((int(final_step), run.final))
    if not points:
        raise ConfigError(f"{str(run.path)!r}: no checkpoint and no final model to score (checkpoints/step_*, final/)")
    return points


def training_seconds(point: Path) -> float:
    """The wall time of training to a saved point (its state's ``seconds``); NaN if it predates that record."""
    try:
        return float(RunFolder.read_state(point).get("seconds", math.nan))
    except (OSError, ValueError, TypeError):
        return math.nan


def read_curve(path: Path) -> dict[int, dict]:
    """A curve.csv by step (empty if none yet)."""
    return {int(r["step"]): r for r in read_board(path)}


def scored_points(curve_path: Path, episodes: int) -> dict[int, dict]:
    """The points of a curve.csv (by step) scored over ``episodes`` episodes: the others were scored on
    another set (another -k or set of levels) and are scored again."""
    return {step: row for step, row in read_curve(curve_path).items() if int(row["episodes"]) == episodes}


def pass_pct(rows: list[dict]) -> float:
    return 100.0 * sum(r["outcome"] != "failed" for r in rows) / len(rows) if rows else math.nan


def curve_row(step: int, seconds: float, rows: list[dict]) -> dict:
    passed = sum(r["outcome"] != "failed" for r in rows)
    return {"step": step, "seconds": seconds, "episodes": len(rows), "passed": passed, "pass_pct": pass_pct(rows)}


def read_board(path: Path) -> list[dict]:
    """A CSV file's rows as dicts of text (none if it does not exist)."""
    if not path.is_file():
        return []
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def csv_text(rows: list[dict], columns: list[str]) -> str:
    """Rows as CSV text, floats with 4 decimals."""
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: (f"{v:.4f}" if isinstance(v, float) else v) for k, v in row.items()})
    return text.getvalue()


def score_curve(
    run: RunFolder,
    cells: list[Cell],
    config: Config,
    echo: Callable[[str], None],
    *,
    every: int = 0,
    final_rows: list[dict] | None = None,
    policy_of: Callable[[Path], str] | None = None,
    needs_model: bool = True,
    trust: bool = False,
    on_episode: Callable[[dict], None] | None = None,
) -> Path:
    """Scores each checkpoint of a trained run (every one, or the first at each multiple of ``every``
    steps) and its final model on the episodes of ``cells`` (``curve/reserved_<step>.csv``, played only
    as far as missing) and writes ``curve.csv``: per point its step, training wall time and pass rate.

    A point already in curve.csv over exactly these episodes is skipped; one scored over others (a
    different -k or set of levels) is scored again, its scoreboard keeping the rows it has. The final
    point is ``final_rows`` if given (a scoreboard already played on these episodes), else the final
    model scored like the checkpoints (a run stopped before its end has no final point).
    ``policy_of(point)`` is the --policy string of a point (default its model.zip).
    Held by one process at a time (InUse names the other)."""
    wanted = {(c.level, c.difficulty, seed) for c in cells for seed in c.seeds}
    curve_path = run.path / "curve.csv"
    policy_of = policy_of or (lambda point: str(point / "model.zip"))
    points = curve_points(run, every, needs_model)
    final_step = points[-1][0] if points[-1][1] == run.final else None

    def own(rows: list[dict]) -> list[dict]:
        return [r for r in rows if (int(r["level"]), int(r["difficulty"]), int(r["seed"])) in wanted]

    with hold(
        curve_path.with_name("curve.csv.lock"),
        lambda pid: f"{str(curve_path)!r}: another process ({pid}) scores this run's curve",
    ):
        curve = scored_points(curve_path, len(wanted))
        done = [step for step, _ in points if step in curve]
        if done:
            echo(f"{curve_path}: {len(done)} point(s) scored on these {len(wanted)} episodes, skipped")
        for step, point in points:
            if step in curve:
                continue
            if step == final_step and final_rows is not None:
                rows = own(final_rows)
            else:
                board = run.path / CURVE_FOLDER / f"reserved_{step:012d}.csv"
                what = "final model" if step == final_step else "checkpoint"
                echo(f"{board}: scoring the {what} at {step} steps on {len(wanted)} episodes")
                policy = resolve(policy_of(point), trust)
                rows = own(evaluate(policy, cells, board, config, on_episode, record=policy_record(policy, "reserved")))
            curve[step] = curve_row(step, training_seconds(point), rows)
            write_atomic(curve_path, csv_text([curve[s] for s in sorted(curve)], CURVE_COLUMNS))
    return curve_path
