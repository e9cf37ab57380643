"""The baseline table: random actions, the reference controller and learned policies (the demo's
PPO, and where their runs exist the student of the reference and PPO in gait mode), each scored on
the reserved seeds of every level and difficulty (``make baselines``, ``make baselines-learned``).

Each policy's scoreboard is the ordinary ``aaai eval`` CSV (``baselines/<name>.csv``); the
episodes are shared out over worker processes one (policy, level) at a time, each writing its own
part (``baselines/parts/``), so an interrupted run resumes where it stopped. From the scoreboards
in the folder (those scored now and those kept from earlier) come ``baselines/table.md`` (pass rates
per level, overall and at difficulties 0, 5 and 10) and ``baselines/heatmap.png`` (the pass rate of
every cell, one panel per policy).
"""

from __future__ import annotations

import csv
import io
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import cv2
import numpy as np

from aaai.files import atomic_path, write_atomic
from aaai.levels import all_levels, get_level
from aaai.scoring.evaluation import COLUMNS, cells_for, evaluate, policy_record, scored_episodes
from aaai.scoring.policies import Policy, resolve
from aaai.train.curriculum import heatmap_panel

SHOWN_DIFFICULTIES = (0, 5, 10)


def one_thread() -> None:
    """A worker scoring episodes uses one torch thread: a policy's small network gains nothing from
    more, and with the default (one per core) the workers fight over the cores (10x the CPU time)."""
    try:
        import torch
    except ImportError:
        return
    torch.set_num_threads(1)


ORDER = ("random", "reference", "ppo_demo", "ppo_gait", "student")  # the table's columns, left to right


def policies(
    demo_run: Path | None, learned: dict[str, Path] | None = None, only: list[str] | None = None
) -> dict[str, Policy]:
    """Name in the table -> the policy, each read once here (a damaged model is refused before any
    work): random, the reference, the demo's run and any other learned runs (``{"student":
    Path("runs/student"), …}``); only the ``only`` ones if given."""
    named = {"random": "random", "reference": "reference"}
    if demo_run is not None:
        named["ppo_demo"] = str(demo_run)
    named.update({name: str(path) for name, path in (learned or {}).items()})
    return {name: resolve(policy) for name, policy in named.items() if only is None or name in only}


def _score_part(policy: Policy, level: int, difficulties: list[int], count: int, part: Path) -> tuple[Path, float]:
    one_thread()
    started = time.perf_counter()
    evaluate(
        policy,
        cells_for([level], difficulties, "reserved", count),
        part,
        policy.config(),
        record=policy_record(policy, "reserved"),
    )
    return part, time.perf_counter() - started


def run(
    out: Path,
    named: dict[str, Policy],
    levels: list[int] | None = None,
    difficulties: list[int] | None = None,
    count: int = 10,
    workers: int = 2,
    echo=print,
) -> dict[str, Path]:
    """Scores every policy of ``named`` (:func:`policies`) on ``count`` reserved seeds per cell;
    the table and heatmap then show every scoreboard in ``out``. Returns the merged scoreboards."""
    levels = sorted(all_levels()) if levels is None else levels
    difficulties = list(range(11)) if difficulties is None else difficulties
    parts = out / "parts"
    parts.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    seconds: dict[str, float] = {name: 0.0 for name in named}
    with ProcessPoolExecutor(max_workers=workers) as pool:
        jobs = {
            pool.submit(_score_part, policy, level, difficulties, count, parts / f"{name}_L{level}.csv"): name
            for name, policy in named.items()
            for level in levels
        }
        for job in jobs:
            part, spent = job.result()
            seconds[jobs[job]] += spent
            echo(f"  {part.name}: {spent:.0f} s")
    scoreboards = {}
    for name in named:
        rows = [row for level in levels for row in scored_episodes(parts / f"{name}_L{level}.csv")]
        rows.sort(key=lambda r: (int(r["level"]), int(r["difficulty"]), int(r["seed"])))
        scoreboards[name] = out / f"{name}.csv"
        write_atomic(scoreboards[name], _csv_text(rows))
    wall = time.perf_counter() - started
    shown = {name: out / f"{name}.csv" for name in ORDER if (out / f"{name}.csv").is_file()}
    shown.update(scoreboards)
    boards = {name: _read(path) for name, path in sorted(shown.items(), key=lambda item: _rank(item[0]))}
    write_atomic(out / "table.md", table_markdown(boards))
    write_heatmap(boards, levels, difficulties, out / "heatmap.png")
    echo(
        f"baselines written to {out} in {wall / 60:.1f} min on {workers} workers ("
        + ", ".join(f"{name} {spent / 60:.1f} min" for name, spent in seconds.items())
        + " of worker time)"
    )
    return scoreboards


def _rank(name: str) -> int:
    return ORDER.index(name) if name in ORDER else len(ORDER)


def _csv_text(rows: list[dict]) -> str:
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=COLUMNS)
    writer.writeheader()
    writer.writerows(rows)
    return text.getvalue()


def _read(path: Path) -> list[dict]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def passed(row: dict) -> bool:
    return row["outcome"] != "failed"


def table_markdown(boards: dict[str, list[dict]]) -> str:
    """Pass rates (passed or succeeded, ratio >= 0.8) per level and policy: overall and at
    difficulties 0, 5 and 10."""
    names = list(boards)
    head = "| level | " + " | ".join(f"{name}: all | d0 / d5 / d10" for name in names) + " |"
    lines = [head, "|---|" + "---:|---:|" * len(names)]
    levels = sorted({int(row["level"]) for rows in boards.values() for row in rows})
    for level in levels + [None]:
        label = "**all levels**" if level is None else f"{get_level(level).label} {get_level(level).name}"
        cells = []
        for name in names:
            rows = [row for row in boards[name] if level is None or int(row["level"]) == level]
            cells.append(_rate(rows))
            cells.append(" / ".join(_rate([r for r in rows if int(r["difficulty"]) == d]) for d in SHOWN_DIFFICULTIES))
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _rate(rows: list[dict]) -> str:
    if not rows:
        return "-"
    return f"{100.0 * sum(map(passed, rows)) / len(rows):.0f}%"


def write_heatmap(boards: dict[str, list[dict]], levels: list[int], difficulties: list[int], path: Path) -> None:
    """One panel per policy: the fraction of episodes passed in each (level, difficulty) cell."""
    cells = [(level, d) for level in levels for d in difficulties]
    panels = []
    for name, rows in boards.items():
        rates, labels = [], []
        for level, d in cells:
            here = [row for row in rows if int(row["level"]) == level and int(row["difficulty"]) == d]
            rates.append(sum(map(passed, here)) / len(here) if here else np.nan)
            labels.append(f"{sum(map(passed, here))}/{len(here)}")
        panels.append(heatmap_panel(f"{name}: passed", np.array(rates), cells, limits=(0.0, 1.0), text=labels))
    picture = np.concatenate(panels, axis=1)
    with atomic_path(path) as temporary:
        if not cv2.imwrite(str(temporary), picture):
            raise OSError(f"OpenCV could not write {path}")
