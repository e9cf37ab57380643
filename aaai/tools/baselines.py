"""The baseline table: random actions, the reference controller and learned policies (the demo's
PPO, and where their runs exist the student of the reference and PPO in gait mode), each scored on
the reserved seeds of every level and difficulty (``make baselines``, ``make baselines-learned``).

Each policy's scoreboard is the ordinary ``aaai eval`` CSV (``baselines/<name>.csv``); the
episodes are shared out over worker processes one (policy, level) at a time, each writing its own
part (``baselines/parts/``), so an interrupted run resumes where it stopped. From the scoreboards
in the folder (those scored now and those kept from earlier) come ``baselines/table.md`` (pass rates
per level, overall and at difficulties 0, 5 and 10) and ``baselines/heatmap.png`` (the pass rate of
every cell, one panel per policy).

With an imported Animal-AI battery (``aaai import-animalai``'s output), :func:`run_battery` scores the
same policies on its arena files instead (the files valid for the body on every seed, seeds 0..K-1),
one ``aaai eval --arenas`` scoreboard each in ``baselines/battery/`` (``<name>.csv``, or
``<name>_sphere.csv`` on Animal-AI's body), and the table gains a section per Olympics category
(:func:`battery_markdown`) from every scoreboard found there.
"""

from __future__ import annotations

import csv
import io
import json
import math
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import cv2
import numpy as np

from aaai.config import ConfigError
from aaai.files import atomic_path, hold, write_atomic
from aaai.jobs import one_thread
from aaai.levels import all_levels, get_level
from aaai.scoring.evaluation import (
    COLUMNS,
    arena_hashes,
    cells_for,
    evaluate,
    evaluate_arenas,
    policy_record,
    scored_episodes,
)
from aaai.scoring.policies import Policy, resolve
from aaai.tools.animalai_arena import CATEGORIES
from aaai.train.curriculum import heatmap_panel
from aaai.train.limbs import LimbsSettings, check_tasks, read_rows

SHOWN_DIFFICULTIES = (0, 5, 10)
PROVENANCE = "provenance.json"  # per scoreboard: how its actions were computed (write_provenance)
BATTERY = "battery"  # the subfolder of the battery's scoreboards (run_battery)
BATTERY_BODIES = ("quadruped", "sphere")
# the first line of every arena file `aaai import-animalai` writes (aaai.tools.animalai)
IMPORTED = "# Imported from an Animal-AI arena file by `aaai import-animalai`"


# the table's columns, left to right (then any other scoreboard named when tabulating)
ORDER = (
    "random",
    "reference",
    "ppo_demo",
    "ppo_gait",
    "student",
    "student_s1",
    "student_food_memory",
    "student_food_memory_s1",
    "student_food_memory_r12",
    "student_food_memory_r12_s1",
    "student_search",
    "student_search_lstm",
    "student_search_sweep",
    "student_search_sweep_s1",
    "student_search_sweep_discrete",
    "student_search_sweep_discrete_s1",
    "student_search_lstm_discrete",
    "student_search_lstm_discrete_s1",
    "student_search_lstm_discrete_r12",
    "student_search_lstm_discrete_r12_s1",
    "student_search_lstm_thorough",
    "student_search_lstm_thorough_s1",
    "student_lstm",
    "student_camera",
)


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
    write_provenance(out, named)
    wall = time.perf_counter() - started
    tabulate(out, list(scoreboards), levels, difficulties)
    echo(
        f"baselines written to {out} in {wall / 60:.1f} min on {workers} workers ("
        + ", ".join(f"{name} {spent / 60:.1f} min" for name, spent in seconds.items())
        + " of worker time)"
    )
    return scoreboards


def tabulate(
    out: Path,
    names: tuple[str, ...] | list[str] = (),
    levels: list[int] | None = None,
    difficulties: list[int] | None = None,
):
    """Writes ``out/table.md`` and ``out/heatmap.png`` from the scoreboards of :data:`ORDER` in
    ``out`` and those of ``names``."""
    levels = sorted(all_levels()) if levels is None else levels
    difficulties = list(range(11)) if difficulties is None else difficulties
    shown = [name for name in ORDER if (out / f"{name}.csv").is_file()] + [n for n in names if n not in ORDER]
    boards = {name: _read(out / f"{name}.csv") for name in sorted(shown, key=_rank)}
    battery = battery_markdown(out / BATTERY)
    if not boards:  # a battery only: no level table, no heatmap
        write_atomic(out / "table.md", battery)
        return
    write_atomic(out / "table.md", table_markdown(boards) + ("\n" + battery if battery else ""))
    write_heatmap(boards, levels, difficulties, out / "heatmap.png")


def write_provenance(out: Path, named: dict[str, Policy]) -> None:
    """Records in ``out/provenance.json`` how each scoreboard just scored was computed: its policy's
    numerics (:data:`aaai.scoring.policies.NUMERICS`, or "none": actions handed on as they are)
    and the package version; the entries of the other scoreboards stay."""
    from aaai import __version__

    path = out / PROVENANCE
    entries = json.loads(path.read_text()) if path.is_file() else {}
    for name, policy in named.items():
        entries[name] = {"numerics": policy.numerics or "none", "aaai_version": __version__}
    write_atomic(path, json.dumps(entries, indent=1, sort_keys=True) + "\n")


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
    """Pass rates (passed or succeeded, ratio >= 0.8) per level and policy, each with its 95 %
    Wilson interval: overall and at difficulties 0, 5 and 10."""
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


def wilson(passes: int, episodes: int, z: float = 1.96) -> tuple[float, float]:
    """The Wilson score interval of a pass rate (95 % for z = 1.96): (low, high), as fractions."""
    rate, spread = passes / episodes, z * z / episodes
    centre = (rate + spread / 2) / (1 + spread)
    half = z * math.sqrt(rate * (1 - rate) / episodes + spread / (4 * episodes)) / (1 + spread)
    return max(0.0, centre - half), min(1.0, centre + half)


def _rate(rows: list[dict]) -> str:
    """The pass rate of ``rows`` with its 95 % Wilson interval: "98% (97-99)"."""
    if not rows:
        return "-"
    passes = sum(map(passed, rows))
    low, high = wilson(passes, len(rows))
    return f"{100.0 * passes / len(rows):.0f}% ({100 * low:.0f}-{100 * high:.0f})"


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


# --- the Animal-AI battery ------------------------------------------------------------------------
def battery_files(folder: Path) -> list[Path]:
    """The arena files at the top of an imported battery (``aaai import-animalai``'s output; its
    unfair/ subfolder left out); ConfigError naming the folder if it is missing, holds none, or holds
    a file the importer did not write."""
    allowed = "allowed: the output folder of `aaai import-animalai` (its fair arena files at the top level)"
    if not folder.is_dir():
        raise ConfigError(f"--battery: got {str(folder)!r}, which is not a folder; {allowed}")
    files = sorted(folder.glob("*.yaml"))
    if not files:
        raise ConfigError(f"--battery: {str(folder)!r} holds no arena files (*.yaml) at its top level; {allowed}")
    for file in files:
        with open(file, encoding="utf-8", errors="replace") as handle:
            first = handle.readline()
        if not first.startswith(IMPORTED):
            raise ConfigError(
                f"--battery: {str(folder)!r} is not an import: {file.name} was not written by "
                f"`aaai import-animalai` (its first line is not the importer's); {allowed}"
            )
    return files


def battery_label(name: str, body: str) -> str:
    """The battery scoreboard's name of a policy on a body: ``reference``, ``reference_sphere``."""
    return name if body == "quadruped" else f"{name}_{body}"


def _score_battery(
    policy: Policy, files: list[Path], seeds: list[int], body: str, record: dict, output: Path
) -> tuple[Path, float]:
    one_thread()
    started = time.perf_counter()
    config = policy.config().replace(body=body)
    evaluate_arenas(policy, files, seeds, output, config, record={**policy_record(policy, "list"), **record})
    return output, time.perf_counter() - started


def run_battery(
    out: Path,
    named: dict[str, Policy],
    battery: Path,
    seeds: int = 1,
    body: str = "quadruped",
    workers: int = 2,
    echo=print,
) -> dict[str, Path]:
    """Scores every policy of ``named`` on the arena files of ``battery`` (:func:`battery_files`)
    that are valid for ``body`` on seeds 0..``seeds``-1 (each file's verdict kept in
    ``out/battery/tasks_<body>.csv``, aaai.train.limbs.check_tasks), one scoreboard a policy
    (``out/battery/<name>.csv``, :func:`battery_label`) as ``aaai eval --arenas`` writes it, resumed
    where it stopped; its record names the battery and each file's SHA-256. The table then shows every
    scoreboard in ``out``. Returns the scoreboards."""
    files = battery_files(battery)
    folder = out / BATTERY
    folder.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    with hold(folder / f".tasks_{body}.lock", lambda pid: f"tasks_{body}.csv is being written by process {pid}"):
        valid = check_tasks(folder, body, LimbsSettings(arenas=tuple(files), arena_seeds=seeds), echo)
    if not valid:
        raise ConfigError(
            f"--battery: no arena file of {str(battery)!r} is valid for the {body} on seeds 0-{seeds - 1}"
        )
    seed_list = list(range(seeds))
    record = {
        "seeds": "list",  # each row names its seed: more --battery-seeds continue the same scoreboard
        "arenas": str(battery.resolve()),  # however it was spelled, and found again by aaai diagnose
        "arena_sha256": arena_hashes(valid),
    }
    boards = {name: folder / f"{battery_label(name, body)}.csv" for name in named}
    seconds: dict[str, float] = {}
    with ProcessPoolExecutor(max_workers=workers) as pool:
        jobs = {
            pool.submit(_score_battery, policy, valid, seed_list, body, record, boards[name]): name
            for name, policy in named.items()
        }
        for job in jobs:
            board, seconds[jobs[job]] = job.result()
            echo(f"  {BATTERY}/{board.name}: {seconds[jobs[job]]:.0f} s")
    tabulate(out)
    wall = time.perf_counter() - started
    echo(
        f"battery scored into {folder} in {wall / 60:.1f} min on {workers} workers ("
        + ", ".join(f"{name} {spent / 60:.1f} min" for name, spent in seconds.items())
        + " of worker time)"
    )
    return boards


def olympics_category(arena: str) -> str:
    """An imported competition file's Olympics category by its name (``01-05-02.yaml``: "01 food
    retrieval"), else "uncategorised"."""
    number = arena[:2]
    return f"{number} {CATEGORIES[number]}" if number in CATEGORIES and arena[2:3] == "-" else "uncategorised"


def _battery_rank(stem: str) -> tuple[int, str, int]:
    for body in BATTERY_BODIES[1:]:
        if stem.endswith(f"_{body}"):
            name = stem.removesuffix(f"_{body}")
            return _rank(name), name, BATTERY_BODIES.index(body)
    return _rank(stem), stem, 0


def battery_markdown(folder: Path) -> str:
    """The table's battery section from every scoreboard in ``folder`` (``out/battery``): a row per
    Olympics category (by the arena file's name) and all categories, a column per policy and body
    (``reference_sphere.csv``: "reference, sphere"): passed/episodes and the pass rate with its 95 %
    Wilson interval. Empty if the folder holds no scoreboard."""
    boards = {}
    for path in sorted(folder.glob("*.csv"), key=lambda p: _battery_rank(p.stem)):
        rows = [row for row in read_rows(path) if row.get("arena")]
        if path.name.startswith("tasks_") or not rows:
            continue
        _, name, body = _battery_rank(path.stem)
        boards[name if body == 0 else f"{name}, {BATTERY_BODIES[body]}"] = rows
    if not boards:
        return ""
    files = {row["arena"] for rows in boards.values() for row in rows}
    categories = [f"{number} {name}" for number, name in CATEGORIES.items()]
    if any(olympics_category(arena) == "uncategorised" for arena in files):
        categories.append("uncategorised")
    lines = [
        f"## Animal-AI battery ({len(files)} files valid on every seed)",
        "",
        "| category | " + " | ".join(boards) + " |",
        "|---|" + "---:|" * len(boards),
    ]
    for category in categories + [None]:
        cells = []
        for rows in boards.values():
            mine = [row for row in rows if category is None or olympics_category(row["arena"]) == category]
            cells.append(f"{sum(map(passed, mine))}/{len(mine)}: {_rate(mine)}" if mine else "-")
        label = "**all categories**" if category is None else category
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


# --- re-scoring committed rows ------------------------------------------------------------------
# What each committed scoreboard of the table was scored with: --policy and --config, relative to
# the baselines folder (None: the default config). Every model of ORDER is committed but these:
# ppo_demo's (make demo trains it) and student_lstm's (a place in the table, no scoreboard committed).
NOT_COMMITTED = ("ppo_demo", "student_lstm")
COMMITTED_MODELS = tuple(  # the models in baselines/models: NAME.zip, scored with NAME.yaml beside it
    name for name in ORDER if name not in ("random", "reference", *NOT_COMMITTED)
)
COMMITTED = {
    "random": ("random", None),
    "reference": ("reference", None),
    **{name: (f"models/{name}.zip", f"models/{name}.yaml") for name in COMMITTED_MODELS},
}
UNTIMED = [column for column in COLUMNS if column != "wall_seconds"]  # what a re-score must repeat


def committed_policy(folder: Path, name: str) -> Policy:
    """The policy of a committed scoreboard (:data:`COMMITTED`), scored with its config."""
    from dataclasses import replace

    from aaai.config import load_config

    policy_name, config_name = COMMITTED[name]
    policy = resolve(policy_name if policy_name in ("random", "reference") else str(folder / policy_name))
    return replace(policy, run_config=load_config(str(folder / config_name))) if config_name else policy


def rescore(folder: Path, name: str, rows: list[dict]) -> list[dict]:
    """Plays again the episodes of ``rows`` (committed rows of ``folder/<name>.csv``) with the policy
    and config they were scored with (:data:`COMMITTED`); their new rows, in order, as strings."""
    from aaai.config import env_part
    from aaai.env import AnimalAIEnv
    from aaai.scoring.evaluation import run_episode

    one_thread()
    policy = committed_policy(folder, name)
    env = AnimalAIEnv(config=env_part(policy.config(), shaping=0.0))
    try:
        acting = policy.build(env)
        played = (run_episode(env, acting, int(r["level"]), int(r["difficulty"]), int(r["seed"])) for r in rows)
        return [{k: str(v) for k, v in row.items()} for row in played]
    finally:
        env.close()


def differing(committed: list[dict], new: list[dict]) -> list[tuple[dict, dict]]:
    """The (committed, new) pairs of rows that differ in any column but the timing."""
    return [(a, b) for a, b in zip(committed, new) if [a[c] for c in UNTIMED] != [b[c] for c in UNTIMED]]
